"""A value of the wrong type for a key or an argument raises mca.Error naming the key, the value and what
to give (as the three-number keys do), not pybind11's "incompatible function arguments"."""
import os

import numpy as np
import pytest

import mca


@pytest.mark.parametrize(
    "table, key, value, said",
    [
        ("solver", "spacing", None, r"solver\.spacing = None is not a number; give a number"),
        ("solver", "spacing", "0.1", r"solver\.spacing = '0\.1' is not a number"),
        ("solver", "spacing", True, r"solver\.spacing = True is not a number"),
        ("solver", "target_automata", 1.5, r"solver\.target_automata = 1\.5 is not a whole number"),
        ("solver", "target_automata", 2**70, r"solver\.target_automata = \d+ is out of range"),
        ("output", "duration", "1", r"output\.duration = '1' is not a number"),
        ("output", "checkpoint_every", 2**40, r"output\.checkpoint_every = \d+ is out of range"),
        ("output", "surface", "yes", r"output\.surface = 'yes' is not True or False"),
        ("output", "vtk", 2, r"output\.vtk = 2 is not True or False"),
        ("output", "vtk", 1, r"output\.vtk = 1 is not True or False"),
        ("output", "surface_format", None, r"output\.surface_format = None is not text"),
        ("solver", "lattice", None, r"solver\.lattice = None is not text"),
        ("solver", "lattice", "hex", r"solver\.lattice = .hex."),
        ("camera", "fov", None, r"camera\.fov = None is not a number"),
        ("ground", "enabled", None, r"ground\.enabled = None is not True or False"),
        ("heterogeneity", "preset", None, r"heterogeneity\.preset = None is not text"),
    ],
)
def test_a_wrong_type_names_the_key(table, key, value, said):
    scene = mca.Scene.default()
    with pytest.raises(mca.Error, match=said):
        setattr(getattr(scene, table), key, value)


def test_wrong_types_on_elements_and_keywords():
    scene = mca.Scene.default()
    with pytest.raises(mca.Error, match=r"projectile\.radius = None is not a number; give a number \(\[m\], > 0\)"):
        scene.projectiles[0].radius = None
    with pytest.raises(mca.Error, match=r"projectile\.kinematic = 0 is not True or False"):
        scene.projectiles[0].kinematic = 0
    with pytest.raises(mca.Error, match=r"object\.radius = 'big' is not a number"):
        scene.objects[0].radius = "big"
    with pytest.raises(mca.Error, match=r"object\.material = None is not text"):
        scene.objects[0].material = None
    with pytest.raises(mca.Error, match=r"object\.shape = 3 is not text"):
        scene.objects[0].shape = 3
    with pytest.raises(mca.Error, match=r"solver\.spacing = 'x' is not a number"):
        mca.Solver(spacing="x")
    with pytest.raises(mca.Error, match=r"material\.youngs_modulus = 'hard' is not a number"):
        mca.Material(name="x", youngs_modulus="hard")
    with pytest.raises(mca.Error, match=r"material\.name = None is not text"):
        mca.Material(name=None)
    with pytest.raises(mca.Error, match=r"scene\.name = 3 is not text"):
        scene.name = 3
    with pytest.raises(mca.Error, match=r"scene\.solver is a int, not an mca\.Solver"):
        scene.solver = 3
    with pytest.raises(mca.Error, match=r"Scene\.from_toml: text = None is not text"):
        mca.Scene.from_toml(None)


def test_right_types_still_taken():
    scene = mca.Scene.default()
    scene.solver.spacing = 1  # an int is a number
    scene.solver.spacing = np.float32(0.05)
    scene.output.duration = np.float64(0.01)
    scene.solver.target_automata = np.int64(1000)
    scene.output.vtk = np.bool_(False)
    scene.output.links = True
    scene.camera.fov = 30
    assert scene.solver.target_automata == 1000 and scene.output.vtk is False and scene.output.links is True
    assert abs(scene.solver.spacing - 0.05) < 1e-8 and scene.camera.fov == 30.0
    scene.solver.target_automata = 0
    scene.validate()


def test_seed_holds_what_the_reader_reads_back():
    scene = mca.Scene.default()
    scene.solver.seed = 2**63  # written as its two's complement, which the reader takes back (docs/scene-format.md)
    assert mca.Scene.from_toml(scene.to_toml()).solver.seed == 2**63
    scene.solver.seed = 2**64 - 1
    assert mca.Scene.from_toml(scene.to_toml()).solver.seed == 2**64 - 1
    with pytest.raises(mca.Error, match=r"solver\.seed = 18446744073709551616 is out of range; give a whole number from -2\^63 to 2\^64 - 1"):
        scene.solver.seed = 2**64
    # A negative seed is its two's complement, as a scene file's (-1 is 2^64 - 1), to -2^63.
    scene.solver.seed = -1
    assert scene.solver.seed == 2**64 - 1
    assert mca.Scene.from_toml(scene.to_toml().replace("seed = 18446744073709551615", "seed = -1")).solver.seed == 2**64 - 1
    scene.solver.seed = -(2**63)
    assert scene.solver.seed == 2**63
    with pytest.raises(mca.Error, match=r"solver\.seed = -9223372036854775809 is out of range"):
        scene.solver.seed = -(2**63) - 1
    with pytest.raises(mca.Error, match=r"solver\.seed = 1\.0 is not a whole number"):
        scene.solver.seed = 1.0
    assert scene.solver.seed == 2**63


def test_wrong_types_of_simulation_arguments():
    scene = mca.Scene.default()
    for threads, said in [(None, "threads = None is not a whole number"), ("2", "threads = '2' is not a whole number"),
                          (1.5, "threads = 1.5 is not a whole number"), (2**40, r"threads = \d+ is out of range")]:
        with pytest.raises(mca.Error, match=said):
            mca.Simulation(scene, threads=threads)
    with pytest.raises(mca.Error, match=r"Simulation: backend = 3 is not text; give a str: \"auto\", \"cpu\""):
        mca.Simulation(scene, backend=3)
    sim = mca.Simulation(scene, threads=1)
    for steps, said in [(None, "advance: steps = None is not a whole number"), (1.5, "advance: steps = 1.5 is not"),
                        (2**70, r"advance: steps = \d+ is out of range")]:
        with pytest.raises(mca.Error, match=said):
            sim.advance(steps)
    with pytest.raises(mca.Error, match="advance_to: time = 'soon' is not a number"):
        sim.advance_to("soon")
    with pytest.raises(mca.Error, match=r"advance_to\(-1\): a simulated time is 0 or more"):
        sim.advance_to(-1)
    with pytest.raises(mca.Error, match=r"render: colour = None is not text; give a str: one of"):
        mca.render(sim, colour=None)
    with pytest.raises(mca.Error, match=r"render: size = 'big' is not two whole numbers; give \(width, height\)"):
        mca.render(sim, size="big")
    with pytest.raises(mca.Error, match=r"render: size\[0\] = 320\.5 is not a whole number"):
        mca.render(sim, size=(320.5, 240))
    with pytest.raises(mca.Error, match=r"checkpoint: path = None is not a path"):
        sim.checkpoint(None)
    assert sim.step == 0


def test_three_number_list_and_path_keys_name_their_table():
    scene = mca.Scene.default()
    with pytest.raises(mca.Error, match=r"projectile\.velocity = None is not three numbers; give \[x, y, z\]"):
        scene.projectiles[0].velocity = None
    with pytest.raises(mca.Error, match=r"solver\.gravity = 'down' is not three numbers"):
        scene.solver.gravity = "down"
    with pytest.raises(mca.Error, match=r"scene\.objects = 3 is not a list; give a list of mca\.Object"):
        scene.objects = 3
    with pytest.raises(mca.Error, match=r"object\.regions = None is not a list; give a list of mca\.Region"):
        scene.objects[0].regions = None
    with pytest.raises(mca.Error, match=r"Scene\.load: path = None is not a path; give a str or a pathlib\.Path"):
        mca.Scene.load(None)
    with pytest.raises(mca.Error, match=r"Scene\.save: path = 3 is not a path"):
        scene.save(3)
    # A list's items are checked when it is set, as a key's value is (they were taken, and refused only by
    # validate(): a hostile review).
    with pytest.raises(mca.Error, match=r"scene\.objects\[1\] is a int, not an mca\.Object; give a list of mca\.Object"):
        scene.objects = [scene.objects[0], 2]
    with pytest.raises(mca.Error, match=r"object\.regions\[0\] is a int, not an mca\.Region"):
        scene.objects[0].regions = [5]
    with pytest.raises(mca.Error, match=r"scene\.materials\[0\] is a Object, not an mca\.Material"):
        scene.materials = [mca.Object()]
    assert len(scene.objects) == 1  # (left as it was)
    scene.objects = list(scene.objects)  # a list is still taken
    scene.validate()


def test_names_given_as_arguments_are_text():
    scene = mca.Scene()
    with pytest.raises(mca.Error, match=r"add_material: name = None is not text; give a str naming the material"):
        scene.add_material(None)
    with pytest.raises(mca.Error, match=r"add_material: base = 3 is not text"):
        scene.add_material("weak", base=3)
    with pytest.raises(mca.Error, match=r"Material\.builtin: name = None is not text"):
        mca.Material.builtin(None)
    with pytest.raises(mca.Error, match=r"Scene: name = 1 is not text"):
        mca.Scene(1)
    assert scene.materials == [] and mca.Scene("x").name == "x"
    assert scene.add_material("weak", base="glass").youngs_modulus == mca.Material.builtin("glass").youngs_modulus


def test_the_lattice_is_chosen_and_round_trips():
    scene = mca.Scene.default()
    assert scene.solver.lattice == "random"  # the default
    assert mca.Solver().lattice == "random"
    scene.solver.lattice = "cubic"
    assert mca.Scene.from_toml(scene.to_toml()).solver.lattice == "cubic"
    assert mca.Solver(lattice="cubic").lattice == "cubic"


def test_a_list_of_numbers_takes_numbers_only():
    """Each component as a single-number key takes it: b"abc" was taken as its three character codes, ("1",
    "2", "3") and (True, False, True) as numbers, and an array of shape (3, 1) as three (the hostile review
    of 2026-12-06)."""
    scene = mca.Scene.default()
    ball = scene.projectiles[0]
    for bad in (b"abc", bytearray(b"abc"), np.zeros((3, 1))):
        with pytest.raises(mca.Error, match=r"(?s)projectile\.velocity = .* is not three numbers; give \[x, y, z\]"):
            ball.velocity = bad
    with pytest.raises(mca.Error, match=r"projectile\.velocity = \('1', '2', '3'\): component 0 = '1' is not a "
                                        r"number; give \[x, y, z\]"):
        ball.velocity = ("1", "2", "3")
    with pytest.raises(mca.Error, match=r"component 1 = False is not a number"):
        ball.velocity = (1.0, False, 1.0)
    with pytest.raises(mca.Error, match=r"heterogeneity\.shares = .*: component 3 = 'x' is not a number"):
        scene.heterogeneity.shares = (0.25, 0.25, 0.25, "x")
    ball.velocity = np.array([1.0, 2.0, 3.0], dtype=np.float32)
    assert ball.velocity == (1.0, 2.0, 3.0)
    ball.velocity = [0, 30, 0.5]
    assert ball.velocity == (0.0, 30.0, 0.5)


def test_text_that_is_not_valid_unicode_is_an_error_and_a_path_is_the_files_own_name(tmp_path):
    """A lone surrogate (os.listdir's name of a file that is not UTF-8) raised pybind11's RuntimeError; as text
    it is mca.Error naming the key, and as a path it is the file's own bytes (the hostile review of
    2026-12-06)."""
    with pytest.raises(mca.Error, match=r"is text that is not valid Unicode \(a lone surrogate\)"):
        mca.Scene("a\udc80b")
    name = os.fsdecode(b"sc\xe8ne.toml")  # 'sc\udce8ne.toml'
    (tmp_path / name).write_text(mca.Scene.default().to_toml())
    assert mca.Scene.load(tmp_path / name) == mca.Scene.default()
    assert mca.Scene.load(str(tmp_path / name)) == mca.Scene.default()


def test_a_file_name_that_is_not_utf8_is_named_in_messages(tmp_path):
    """An error naming such a file came back as mca.Error('') and Scene.source or repr raised
    UnicodeDecodeError (the hostile review of 2026-12-06): the messages show its bytes as \\xNN, and source
    gives the name back as os.fsdecode does."""
    name = os.fsdecode(b"sc\xe8ne.toml")
    path = tmp_path / name
    path.write_text(mca.Scene.default().to_toml().replace("spacing =", "spacnig =", 1))
    with pytest.raises(mca.Error) as e:
        mca.Scene.load(path)
    assert "sc\\xe8ne.toml" in str(e.value) and "spacing" in str(e.value)
    path.write_text(mca.Scene.default().to_toml())
    scene = mca.Scene.load(path)
    assert scene.source == str(path)
    assert "sc\\xe8ne.toml" in repr(scene)
