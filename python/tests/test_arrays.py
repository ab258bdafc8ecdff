"""The state as numpy arrays: shapes and dtypes as documented, copies that do not change, views that are
read-only, and every array valid after the Simulation is gone."""
import gc

import numpy as np
import pytest

import mca


@pytest.fixture
def sim():
    s = mca.Simulation(mca.Scene.default(), threads=2)
    s.advance(6000)  # the ball strikes after about 3,400 steps
    return s


def test_shapes_and_dtypes(sim):
    n = sim.automata
    assert n == 4800
    expected = {
        "positions": ((n, 3), np.float64),
        "velocities": ((n, 3), np.float64),
        "angular_velocities": ((n, 3), np.float64),
        "rotations": ((n, 4), np.float32),
        "damage": ((n,), np.float32),
        "fragment_ids": ((n,), np.int32),
        "strength_class": ((n,), np.uint8),
        "masses": ((n,), np.float32),
        "object_ids": ((n,), np.int32),
    }
    for name, (shape, dtype) in expected.items():
        a = getattr(sim, name)()
        assert a.shape == shape and a.dtype == dtype, name
    links = sim.links()
    assert links.dtype == np.uint32 and links.shape[1] == 2
    assert len(links) == sim.link_count - sim.broken_links()["total"]
    assert np.all(links[:, 0] < links[:, 1])
    assert np.allclose(np.linalg.norm(sim.rotations(), axis=1), 1, atol=1e-5)
    assert set(np.unique(sim.strength_class())) <= {1, 2, 3, 4}
    assert 0 < sim.damage().max() <= 1
    p = sim.projectiles()
    assert p["name"] == ["ball"] and p["position"].shape == (1, 3) and p["radius"][0] == pytest.approx(0.2)
    # The fragments' masses add up to the automata's.
    assert sim.fragments()["mass"].sum() == pytest.approx(float(sim.masses().astype(np.float64).sum()), rel=1e-9)
    assert sim.fragment_ids().max() + 1 == len(sim.fragments()["id"])


def test_state_arrays_are_copies(sim):
    x = sim.positions()
    kept = x.copy()
    x[:] = 0  # writing into a copy changes nothing in the simulation
    assert np.array_equal(sim.positions(), kept)
    assert not np.shares_memory(sim.positions(), sim.positions())
    sim.advance(200)  # the ball moves on: a copy taken before keeps its values
    assert np.array_equal(x, np.zeros_like(x))
    assert not np.array_equal(sim.positions(), kept)


def test_model_arrays_are_read_only_views(sim):
    a, b = sim.strength_class(), sim.strength_class()
    assert np.shares_memory(a, b)
    for view in (a, sim.masses(), sim.object_ids()):
        assert not view.flags.writeable
        with pytest.raises(ValueError):
            view[0] = 1


def test_arrays_survive_the_simulation(sim):
    arrays = {name: getattr(sim, name)() for name in ("positions", "rotations", "strength_class", "masses", "damage")}
    saved = {name: a.copy() for name, a in arrays.items()}
    del sim
    gc.collect()
    # Fill the memory the simulation freed, if it were freed under the views.
    junk = [np.full(4800 * 8, 7, dtype=np.uint8) for _ in range(50)]
    for name, a in arrays.items():
        assert np.array_equal(a, saved[name]), name
    del junk


def test_progress_callback_and_advance_to():
    sim = mca.Simulation(mca.Scene.default(), threads=2)
    calls = []
    sim.advance(300, progress=lambda done, total: calls.append((done, total)))
    assert calls and calls[-1] == (300, 300)
    assert all(total == 300 for _, total in calls) and [d for d, _ in calls] == sorted(d for d, _ in calls)
    sim.advance_to(0.002)
    assert sim.time == pytest.approx(0.002, abs=sim.time_step / 2)
    sim.advance_to(0.001)  # in the past: nothing
    assert sim.time == pytest.approx(0.002, abs=sim.time_step / 2)


def test_first_arrays_read_by_several_threads_at_once(tmp_path):
    """Two threads reading their own simulations' first arrays, numpy not imported by the script: pybind11
    set numpy up at the first array under a lock while holding the GIL, and the threads deadlocked (a hostile
    review, 2026-12-06: five runs of five). The module sets numpy up at its import."""
    import os
    import subprocess
    import sys
    script = (
        "import sys, threading\n"
        "import mca\n"
        "sc = mca.Scene.default()\n"
        "sc.output.duration = 0.001\n"
        "sims = [mca.Simulation(sc, threads=1) for _ in range(4)]\n"
        "ts = [threading.Thread(target=lambda s=s: [s.positions() for _ in range(20)]) for s in sims]\n"
        "[t.start() for t in ts]\n"
        "[t.join() for t in ts]\n"
        "print('done')\n")
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(mca.__file__)))
    for _ in range(3):
        r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, env=env,
                           cwd=tmp_path)
        assert r.returncode == 0 and r.stdout.strip() == "done", (r.returncode, r.stdout, r.stderr[-2000:])
