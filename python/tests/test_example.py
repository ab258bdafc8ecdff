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


def test_speed_sweep_refuses_a_duration_that_is_no_time(source_dir):
    for bad in ("abc", "-1", "0", "inf"):
        r = subprocess.run([sys.executable, str(source_dir / "examples" / "speed_sweep.py"), bad],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 1 and "is not a positive number of simulated seconds" in r.stderr, (bad, r.stderr)
        assert "Traceback" not in r.stderr
