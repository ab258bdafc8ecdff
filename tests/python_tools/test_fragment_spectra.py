"""Tests of tools/fragment_spectra.py: runs side by side, each run's n(m) in its colour, the band, clear
errors (run with /usr/bin/python3 -m pytest tests/python_tools)."""
import json
import os
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools"))
import fracture_metrics as fm  # noqa: E402

pytest.importorskip("matplotlib")

from test_fracture_metrics import sample_power_law, write_fragments  # noqa: E402

TOOL = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "fragment_spectra.py")


def fake_run(folder, sizes):
    folder.mkdir()
    write_fragments(folder / "fragments.csv", sizes, 0.3)
    dist = fm.summary_form(fm.fragment_measure(str(folder)))
    (folder / "summary.json").write_text(json.dumps({"fragment_mass_distribution": dist}))
    return dist


def run_tool(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


def test_two_panels_of_runs_are_drawn(tmp_path):
    fake_run(tmp_path / "a", sample_power_law(1.8, 127, 1e4))
    fake_run(tmp_path / "b", sample_power_law(3.0, 63, 1e4))
    out = tmp_path / "fig.png"
    r = run_tool("--out", str(out), f"left = 1=A:{tmp_path / 'a'},B:{tmp_path / 'b'}", f"right=A:{tmp_path / 'a'}")
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")], "a temporary file was left"


def test_a_run_without_a_distribution_is_a_clear_error(tmp_path):
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "summary.json").write_text("{}")
    r = run_tool("--out", str(tmp_path / "f.png"), f"t=A:{tmp_path / 'old'}")
    assert r.returncode != 0
    assert "has no fragment mass distribution" in r.stderr
    r = run_tool("--out", str(tmp_path / "f.png"), f"t=A:{tmp_path / 'missing'}")
    assert r.returncode != 0 and "(the run labelled 'A') is not a folder" in r.stderr
    # A summary that is not an object, and a folder named with the syntax's ',' or '=': one line each.
    (tmp_path / "list").mkdir()
    (tmp_path / "list" / "summary.json").write_text("[]")
    r = run_tool("--out", str(tmp_path / "f.png"), f"t=A:{tmp_path / 'list'}")
    assert r.returncode != 0 and "is not a JSON object" in r.stderr and "Traceback" not in r.stderr
    (tmp_path / "g=100,v30").mkdir()
    r = run_tool("--out", str(tmp_path / "f.png"), f"t=A:{tmp_path / 'g=100,v30'}")
    assert r.returncode != 0 and "give a symbolic link to it" in r.stderr
    r = run_tool("--out", str(tmp_path / "f.png"), "no groups here")
    assert r.returncode != 0 and "TITLE=LABEL:RUN" in r.stderr
    assert not (tmp_path / "f.png").exists()
