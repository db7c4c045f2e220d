"""The Python example runs end to end on the Gravity Truck passes and writes its figure."""
import os
import subprocess
import sys

from conftest import ROOT, data_file


def test_the_gravity_truck_example_calibrates_and_plots(tmp_path):
    data_file("gravity/Truck.las")
    out = tmp_path / "truck.png"
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "gravity_truck.py"), "--out", str(out)],
                         capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="Agg"), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20000
    lines = dict(line.split(": ", 1) for line in run.stdout.splitlines() if ": " in line)
    assert lines["verdict"] == "accept"
    before = float(lines["discrepancy before"].split()[1])
    after = float(lines["discrepancy after"].split()[1])
    assert before > 0.3 and after < 0.03  # the median pass-to-pass discrepancy, metres
