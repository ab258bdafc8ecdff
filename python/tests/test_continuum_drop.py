"""A concrete cube dropped flat on the ground, against continuum mechanics (tools/continuum_drop.py, finite
elements with nothing of mca's in them; docs/model-notes.md, "Drops").

The compressed cube leaves the ground vibrating, and the vibration stretches its middle. In an elastic
continuum that takes Poisson's ratio (a 1-D bar leaves clean); mca's materials are also viscous (Kelvin-Voigt,
damping_time), and the viscosity alone does it too: it smears the unloading wave, and the cube leaves the
ground with its parts moving unevenly. The continuum of mca's material (the same viscosity) stretches the
middle by 9.2e-5 at Poisson's ratio 0 and 1.03e-4 at 0.2, 0.21 ms after touching down (at 1 m/s:
concrete's tensile strength). Both lattices must show that, at both ratios and both spacings, in size and
in time, and leave the ground as fast; the random lattice's few broken links at that speed
(tests/test_impact.cpp, Drops) come from it.
"""
import importlib.util

import numpy as np
import pytest

import mca
from conftest import SOURCE_DIR

SIZE, SPEED = 0.3, 1.0


def load_tool():
    path = SOURCE_DIR / "tools" / "continuum_drop.py"
    spec = importlib.util.spec_from_file_location("continuum_drop", path)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    return tool


tool = load_tool()


REFERENCES = {}


def continuum(poisson, damping_time, cells=12, viscosity="isotropic"):
    key = (poisson, damping_time, cells, viscosity)
    if key not in REFERENCES:
        r = tool.drop(cells=cells, poisson=poisson, size=SIZE, speed=SPEED, duration=0.45e-3,
                      damping_time=damping_time, viscosity=viscosity)
        REFERENCES[key] = r, tool.first_tension_peak(r["t"], r["strain"])
    return REFERENCES[key]


def test_the_reference_leaves_a_one_dimensional_elastic_cube_unstretched():
    # Poisson's ratio 0, elastic: bars side by side, which leave the ground at their speed with no stress;
    # the tension at 0.2 is the three-dimensional body's, not the method's. (What is left at 0 is the
    # elements' ringing behind the front: 3.3e-5, 1.2e-5, 1.05e-5 at 12, 16 and 24 cells.)
    r, peak = continuum(0.0, 0.0, cells=16)
    three_d = continuum(0.2, 0.0, cells=16)
    compressed = -r["strain"].min()
    assert compressed == pytest.approx(SPEED / np.sqrt(30e9 / 2400.0), rel=0.1)  # v / c: 2.8e-4
    assert peak is None or peak[1] < 0.2 * three_d[1][1], (peak, three_d[1])
    assert r["velocity"][-1] > 0.93 * SPEED  # it leaves at its speed (less its bottom nodes' stop)
    # With 0.2 the middle is stretched by over a third of its compression.
    assert three_d[1][1] > 0.35 * -three_d[0]["strain"].min()


def lattice_drop(lattice, spacing, poisson, duration=0.45e-3, every=2.5e-6):
    """The middle bands' strain of an mca cube touching the ground at t = 0 (tool.BANDS on the automata),
    and its mean vertical velocity at the end."""
    scene = mca.Scene.from_toml(f"""
name = "drop"
[solver]
spacing = {spacing}
lattice = "{lattice}"
gravity = [0.0, 0.0, 0.0]
[output]
duration = 0.01
frame_rate = 100
[ground]
enabled = true
[[material]]
name = "c"
base = "concrete"
poisson_ratio = {poisson}
[[object]]
name = "cube"
shape = "box"
size = [{SIZE}, {SIZE}, {SIZE}]
position = [0.0, 0.0, {SIZE / 2}]
velocity = [0.0, 0.0, {-SPEED}]
material = "c"
""")
    sim = mca.Simulation(scene, threads=1)
    z0 = sim.positions()[:, 2]
    lo = np.abs(z0 - tool.BANDS[0] * SIZE) <= tool.BAND_HALF_WIDTH * SIZE
    hi = np.abs(z0 - tool.BANDS[1] * SIZE) <= tool.BAND_HALF_WIDTH * SIZE
    assert lo.sum() >= 4 and hi.sum() >= 4
    gap0 = z0[hi].mean() - z0[lo].mean()
    chunk = max(1, round(every / sim.time_step))
    t, strain = [], []
    while sim.time < duration:
        sim.advance(chunk)
        z = sim.positions()[:, 2]
        t.append(sim.time)
        strain.append(((z[hi].mean() - z[lo].mean()) - gap0) / gap0)
    return np.array(t), np.array(strain), sim.velocities()[:, 2].mean()


@pytest.mark.parametrize("lattice", ["cubic", "random"])
@pytest.mark.parametrize("spacing", [0.05, 0.025])
@pytest.mark.parametrize("poisson", [0.0, 0.2])
def test_the_lattices_middle_is_stretched_as_the_continuums(lattice, spacing, poisson):
    t, strain, leaving = lattice_drop(lattice, spacing, poisson)
    peak = tool.first_tension_peak(t, strain)
    # Concrete's damping_time, the cubic lattice's viscosity on the axes' stretching alone, the random
    # lattice's on links every way (the isotropic kind). The random lattice's tension grows faster with
    # Poisson's ratio than the continuum's: 1.20 to 1.25 times it at 0.2 (this test does not measure the
    # ratio: Physics.BlockInUniaxialStressReturnsYoungsModulusAndPoissonRatio and
    # RandomLattice.ABlockReturnsTheInputModulusAndPoissonRatio do).
    axial = lattice == "cubic"
    ref_run, ref = continuum(poisson, 5e-6, viscosity="axial" if axial else "isotropic")
    print(f"{lattice} lattice at {spacing} m, Poisson's ratio {poisson}: compressed {-strain.min():.3e} "
          f"(continuum {-ref_run['strain'].min():.3e}), first tension {peak} (continuum {ref}), leaving at "
          f"{leaving:.3f} m/s (continuum {ref_run['velocity'][-1]:.3f})")
    assert -strain.min() == pytest.approx(-ref_run["strain"].min(), rel=0.15)
    assert peak is not None
    assert 0.9 * ref[1] <= peak[1] <= (1.2 if axial else 1.3) * ref[1]
    assert peak[0] == pytest.approx(ref[0], rel=0.1)
    assert leaving == pytest.approx(ref_run["velocity"][-1], rel=0.1)
