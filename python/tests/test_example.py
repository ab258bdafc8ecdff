"""examples/speed_sweep.py: the scripted parameter sweep of the README, run short."""
import subprocess
import sys


def test_speed_sweep_example(source_dir):
    r = subprocess.run([sys.executable, str(source_dir / "examples" / "speed_sweep.py"), "0.006"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stdout.splitlines() if "m/s" in line]
    assert len(lines) == 3
    broken = [int(line.split("m/s:")[1].split()[0]) for line in lines]
    # A faster ball breaks more links.
    assert broken[0] < broken[1] < broken[2], r.stdout
