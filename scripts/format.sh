#!/usr/bin/env bash
# Formats the C++ sources with the committed .clang-format (Debian's clang-format).
#   scripts/format.sh          rewrite every tracked .cpp/.hpp in place
#   scripts/format.sh --check  change nothing; list the files that are not formatted, exit 1 if any
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=deps.sh
source "$root/scripts/deps.sh"
MOUNTCAL_DEPS=()  # only the formatter is needed here
mountcal_ensure_deps clang-format
cd "$root"
mapfile -t files < <(git ls-files '*.cpp' '*.hpp')
if [ "${1:-}" = "--check" ]; then
  bad=()
  for f in "${files[@]}"; do
    clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
  done
  if [ ${#bad[@]} -gt 0 ]; then
    printf 'not formatted (run scripts/format.sh): %s\n' "${bad[@]}" >&2
    exit 1
  fi
  echo "format: ${#files[@]} files formatted as .clang-format says"
else
  clang-format -i "${files[@]}"
fi
