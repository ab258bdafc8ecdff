"""The module steps the command's engine: the same scene gives the command's state_hash, fragments and
energies, bit for bit."""
import csv
import json

import numpy as np

import mca
from conftest import run_command

STEPS = 6000  # past the ball's contact with the wall (about 3,400 steps): links break


def test_default_scene_gives_the_commands_state_hash(tmp_path, mca_binary):
    out = tmp_path / "run"
    run_command(mca_binary, "run", "--steps", STEPS, "--no-vtk", "--quiet", "--threads", 2, "--out", out)
    summary = json.loads((out / "summary.json").read_text())

    sim = mca.Simulation(mca.Scene.default(), threads=2)
    sim.advance(STEPS)
    assert sim.step == summary["steps"] == STEPS
    assert sim.state_hash() == summary["state_hash"]
    assert sim.broken_links() == summary["broken_links"]
    assert summary["broken_links"]["total"] > 0, "the ball must have broken links by then"
    # The scene the command ran (its scene.toml, with --no-vtk applied) is the module's default scene.
    expected = mca.Scene.default()
    expected.output.vtk = False
    assert mca.Scene.load(out / "scene.toml") == expected

    energy = sim.energies()
    for key, value in summary["energy"].items():
        assert energy[key] == value, key

    # fragments() holds the columns of fragments.csv, the same numbers (shortest round-trip text).
    with open(out / "fragments.csv") as f:
        rows = list(csv.DictReader(f))
    frags = sim.fragments()
    assert list(frags.keys()) == list(rows[0].keys())
    assert len(frags["id"]) == len(rows) == summary["fragment_count"]
    for name, column in frags.items():
        expected = np.array([float(r[name]) for r in rows])
        assert np.array_equal(column.astype(np.float64), expected), name
    assert frags["id"].dtype == np.int32 and frags["automata"].dtype == np.int64


def test_thread_counts_and_slicing_change_no_bit():
    a = mca.Simulation(mca.Scene.default(), threads=1)
    b = mca.Simulation(mca.Scene.default(), threads=2)
    a.advance(4000)  # the ball strikes after about 3,400 steps
    for _ in range(40):  # 40 calls' worth of slices against one call
        b.advance(100)
    assert a.state_hash() == b.state_hash()
