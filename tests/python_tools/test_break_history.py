"""Tests of tools/break_history.py on a fake run folder: a row of three automata along x, its two links
broken at known steps by known criteria, and a checkpoint that holds those records at its end."""
import json
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools"))
import break_history as bh  # noqa: E402
from test_fracture_metrics import write_vtu  # noqa: E402

D = 0.05


def checkpoint(records, by, grips=0, body=b"state bytes"):
    """A format-7 checkpoint's layout from the break records on: what comes before is not read."""
    out = bytearray(bh.MAGICS[-1] + body)
    out += struct.pack("<Q", len(records))
    for step, link, crit in records:
        out += struct.pack("<qIB", step, link, crit)
    out += struct.pack("<qq", *by) + struct.pack("<d", 123.0)
    out += struct.pack("<Q", grips) + b"\0" * (8 * grips) + struct.pack("<Q", grips) + b"\0" * (12 * grips)
    out += struct.pack("<Q", bh.fnv1a(bytes(out))) + bh.MAGICS[-1]
    return bytes(out)


def test_break_records_are_read_from_the_end(tmp_path):
    recs = [(10, 0, 1), (15, 1, 0), (15, 4, 1)]
    for grips in (0, 2):
        p = tmp_path / f"c{grips}.mcack"
        p.write_bytes(checkpoint(recs, (1, 2), grips))
        rec, by = bh.read_breaks(p)
        assert by == {"displacement": 1, "stress": 2}
        assert [tuple(int(v) for v in r) for r in rec.tolist()] == recs
    p.write_bytes(checkpoint(recs, (2, 2)))  # counts that do not match the records
    with pytest.raises(bh.fm.RunError, match="break records"):
        bh.read_breaks(p)
    damaged = bytearray(checkpoint(recs, (1, 2)))
    damaged[10] ^= 1  # a flipped bit before the records
    p.write_bytes(bytes(damaged))
    with pytest.raises(bh.fm.RunError, match="checksum"):
        bh.read_breaks(p)
    assert len(bh.read_breaks(p, verify=False)[0]) == 3


def test_the_checkpoints_mca_writes_are_read(tmp_path):
    """A checkpoint written by the built mca (MCA_BINARY, set by ctest), not one laid out by this file: the
    tool follows mca's format, and its records are the run's broken links."""
    binary = os.environ.get("MCA_BINARY")
    if not binary:
        pytest.skip("MCA_BINARY (the built mca) is not set: ctest sets it")
    scene = tmp_path / "small.toml"
    scene.write_text("""name = "small"
[[object]]
shape = "box"
size = [0.6, 0.1, 0.6]
position = [0, 0, 0.35]
material = "concrete"
[[projectile]]
radius = 0.1
position = [0, -0.151, 0.35]
velocity = [0, 60, 0]
material = "steel"
[output]
duration = 0.001
frame_rate = 2000
vtk = false
[solver]
spacing = 0.05
lattice = "cubic"
""")
    out = tmp_path / "run"
    subprocess.run([binary, "run", str(scene), "--out", str(out), "--threads", "1", "-q", "--checkpoint-every", "1"],
                   check=True)
    broken = json.loads((out / "summary.json").read_text())["broken_links"]
    assert broken["total"] > 0
    newest = sorted((out / "checkpoints").glob("frame_*.mcack"))[-1]
    assert newest.read_bytes()[:8] == bh.MAGICS[-1], "mca writes a checkpoint format this tool does not know"
    rec, by = bh.read_breaks(newest)
    assert by == {"displacement": broken["displacement"], "stress": broken["stress"]}
    assert len(rec) == broken["total"]


def test_checksum_is_the_projects_fnv1a():
    # src/core/fnv.hpp: h = 1469598103934665603; h ^= byte; h *= 1099511628211 (mod 2^64)
    assert bh.fnv1a(b"") == 1469598103934665603
    assert bh.fnv1a(b"a") == ((1469598103934665603 ^ 0x61) * 1099511628211) % 2 ** 64


def test_lattice_neighbours():
    pos = np.array([[0, 0, 0], [D, 0, 0], [2 * D, 0, 0], [0, 0, D]], float) + 0.3
    up = bh.lattice_neighbours(pos, np.zeros(4, int), D)
    assert up[0].tolist() == [1, 2, -1, -1]
    assert up[1].tolist() == [-1, -1, -1, -1]
    assert up[2].tolist() == [3, -1, -1, -1]


def fake_run(tmp_path):
    n = 3
    pos = np.array([[-D, 0, 0.75], [0, 0, 0.75], [D, 0, 0.75]])
    frames = tmp_path / "frames"
    frames.mkdir()
    fields = lambda frag: {"displacement": np.zeros((n, 3)), "strength_class": np.array([4, 2, 4], np.int32),
                           "object": np.zeros(n, np.int32), "fragment": np.array(frag, np.int32),
                           "damage": np.array([0.0, 0.0, 0.0]) if frag == [0, 0, 0] else np.ones(n)}
    write_vtu(frames / "automata_000000.vtu", pos, fields([0, 0, 0]))
    write_vtu(frames / "automata_000001.vtu", pos, fields([0, 1, 2]))
    (tmp_path / "automata.pvd").write_text(
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian"><Collection>\n'
        '<DataSet timestep="0" file="frames/automata_000000.vtu"/>\n'
        '<DataSet timestep="0.002" file="frames/automata_000001.vtu"/>\n</Collection></VTKFile>\n')
    (tmp_path / "summary.json").write_text(json.dumps({"spacing": D, "time_step": 1e-6}))
    (tmp_path / "scene.toml").write_text(
        '[[object]]\nposition = [0.0, 0.0, 0.75]\n[[projectile]]\nposition = [0.0, -0.4, 0.75]\n'
        'velocity = [0.0, 30.0, 0.0]\n')
    (tmp_path / "checkpoints").mkdir()
    # slot 0: automata 0-1 (x), broken at step 10 by stress; slot 1: 1-2, at step 15 by displacement
    (tmp_path / "checkpoints" / "frame_000001.mcack").write_bytes(checkpoint([(10, 0, 1), (15, 1, 0)], (1, 1)))
    return tmp_path


def test_singles_and_their_breaks(tmp_path):
    r = bh.analyse(str(fake_run(tmp_path)))
    assert r["singles"] == 3 and r["breaks"] == 2 and r["first_break_step"] == 10
    s = r["single_spread_steps"]
    # automaton 1 lost its links at steps 10 and 15; the ends lost theirs at once (one link each)
    assert s["all_in_one_step"] == 2 and s["within_10"] == 3 and s["median"] == 0.0
    assert r["single_links_in_last_step"]["1"] == 3
    assert r["single_link_criteria"] == {"displacement": 2, "stress": 2}  # each link counted from both ends
    assert r["single_link_weaker_end"] == {"single weaker": 2, "equal": 0, "single stronger": 2}
    assert r["single_class"]["2"][0] == 1 and r["single_class"]["4"][0] == 2
    assert r["broken_by_axis"] == [2, 0, 0]
    assert r["damaged_automata_by_broken_links"]["2"] == 1 and r["damaged_automata_by_broken_links"]["1"] == 2
    assert r["singles_over_time"] == [[0.0, 0], [0.002, 3]]
    assert r["breaks_sharing_an_automaton_with_a_break_of_the_same_step"] == 0
    assert r["steps_between_last_two_breaks"] == {"median": 5.0, "within_10": 1, "count": 1}
