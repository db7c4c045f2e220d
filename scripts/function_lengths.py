#!/usr/bin/env python3
"""Lists the functions of src/ longer than a limit (default 120 lines), longest first.

A function is a definition that opens at the start of a line (namespace scope) or one indent
level in (a member defined in a class body) and ends at its matching brace; string and comment
braces are skipped. Usage: scripts/function_lengths.py [LIMIT] — exit 1 when one is longer."""
import os, re, sys

limit = int(sys.argv[1]) if len(sys.argv) > 1 else 120
root = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src')
start = re.compile(r'^(?:  )?(?!(?:if|for|while|switch|return|else|namespace|struct|class|enum|union)\b)[A-Za-z_~][^;{}()]*\([^;]*$')

def strip(line):
    line = re.sub(r'"(?:\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(?:\\.|[^'\\])*'", "''", line)
    return line.split('//')[0]

found = []
for dirpath, _, names in os.walk(root):
    for name in names:
        if not name.endswith(('.cpp', '.hpp')):
            continue
        path = os.path.join(dirpath, name)
        lines = open(path, encoding='utf-8', errors='replace').read().split('\n')
        i = 0
        while i < len(lines):
            if start.match(lines[i]):
                # the signature runs until the line holding its opening brace
                j = i
                while j < len(lines) and '{' not in strip(lines[j]) and ';' not in strip(lines[j]):
                    j += 1
                if j < len(lines) and '{' in strip(lines[j]) and ';' not in strip(lines[j]).split('{')[0]:
                    depth, k = 0, j
                    while k < len(lines):
                        s = strip(lines[k])
                        depth += s.count('{') - s.count('}')
                        if depth <= 0:
                            break
                        k += 1
                    n = k - i + 1
                    if n > limit:
                        found.append((n, os.path.relpath(path, os.path.join(root, '..')), i + 1, lines[i].strip()[:80]))
                    i = k + 1
                    continue
            i += 1
for n, path, line, sig in sorted(found, reverse=True):
    print(f'{n:5d}  {path}:{line}  {sig}')
sys.exit(1 if found else 0)
