"""Scenes from files and from Python: the keys of docs/scene-format.md, and to_toml / from_toml giving
back the same scene."""
import pathlib

import pytest

import mca


def example_scenes(source_dir):
    # The scenes without meshes (those need the paper's models, scripts/get_models.sh).
    return [p for p in sorted((source_dir / "scenes").glob("*.toml")) if "mesh" not in p.read_text()]


def test_scene_files_round_trip(source_dir):
    scenes = example_scenes(source_dir)
    assert len(scenes) >= 5
    for path in scenes:
        scene = mca.Scene.load(path)
        text = scene.to_toml()
        again = mca.Scene.from_toml(text, str(path))
        assert again == scene, path
        assert again.to_toml() == text, path


def test_a_scene_built_in_python_is_the_scene_written_in_toml():
    scene = mca.Scene("slab")
    scene.add_material("weak", base="concrete", tensile_strength=1.5e6, strengthening="quadratic",
                       strengthening_alpha=10.0)
    slab = scene.add_object(name="slab", size=(1.0, 0.1, 0.5), position=(0, 0, 0.25), material="concrete")
    slab.add_region(shape="sphere", center=(0, 0, 0.25), radius=0.15, material="weak")
    slab.heterogeneity = mca.Heterogeneity(preset="high", grain_size=0.1)
    scene.add_projectile(radius=0.05, position=(0, -0.2, 0.25), velocity=(0, 40, 0))
    scene.add_projectile(radius=0.04, position=(0.3, -0.2, 0.25), velocity=(0, 20, 0), kinematic=True)
    scene.add_grip(min=(-0.6, -0.1, 0), max=(-0.4, 0.1, 0.5))
    scene.add_load(min=(0.4, -0.1, 0), max=(0.6, 0.1, 0.5), force=(0, 0, -1))
    scene.solver.spacing = 0.025
    scene.solver.seed = 7
    scene.heterogeneity.preset = "low"
    scene.output.duration = 0.004
    scene.output.frame_rate = 1000
    scene.ground.enabled = True
    scene.camera.fov = 30
    scene.camera.position = (2, -3, 1)
    scene.validate()

    written = mca.Scene.from_toml(
        """
name = "slab"
[solver]
spacing = 0.025
seed = 7
[output]
duration = 0.004
frame_rate = 1000.0
[heterogeneity]
preset = "low"
[ground]
enabled = true
[camera]
fov = 30.0
position = [2, -3, 1]
[[material]]
name = "weak"
base = "concrete"
tensile_strength = 1.5e6
strengthening = "quadratic"
strengthening_alpha = 10.0
[[object]]
name = "slab"
size = [1.0, 0.1, 0.5]
position = [0, 0, 0.25]
material = "concrete"
[object.heterogeneity]
preset = "high"
grain_size = 0.1
[[object.region]]
shape = "sphere"
center = [0, 0, 0.25]
radius = 0.15
material = "weak"
[[projectile]]
radius = 0.05
position = [0, -0.2, 0.25]
velocity = [0, 40, 0]
[[projectile]]
radius = 0.04
position = [0.3, -0.2, 0.25]
velocity = [0, 20, 0]
kinematic = true
[[grip]]
min = [-0.6, -0.1, 0]
max = [-0.4, 0.1, 0.5]
[[load]]
min = [0.4, -0.1, 0]
max = [0.6, 0.1, 0.5]
force = [0, 0, -1]
""",
        "<python>",
    )
    assert written == scene
    assert mca.Scene.from_toml(scene.to_toml()) == scene
    # Names by index as the reader gives them.
    assert [p.name for p in scene.projectiles] == ["ball", "ball1"]
    sim = mca.Simulation(scene, threads=1)
    assert sim.automata == 40 * 4 * 20
    assert set(sim.strength_class()) <= {1, 2, 3, 4}


def test_changes_stick_and_copies_are_deep():
    scene = mca.Scene.default()
    wall = scene.objects[0]
    wall.size = [1.0, 0.2, 1.0]
    scene.projectiles[0].velocity = (0, 50, 0)
    scene.add_object(name="second", position=(0, 2, 0.5))  # the list grows; `wall` stays the wall
    wall.position = (0, 0, 0.5)
    assert scene.objects[0].size == (1.0, 0.2, 1.0) and scene.objects[0].position == (0, 0, 0.5)
    assert mca.Scene.from_toml(scene.to_toml()).projectiles[0].velocity == (0, 50, 0)
    copy = scene.copy()
    copy.objects[0].size = (3, 3, 3)
    copy.solver.spacing = 0.1
    assert scene.objects[0].size == (1.0, 0.2, 1.0) and scene.solver.spacing == 0.05
    h = mca.Heterogeneity(preset="medium")
    assert h.shares == pytest.approx((0, 0.15, 0.2, 0.65))
    h.shares = (0.25, 0.25, 0.25, 0.25)
    assert h.preset == "custom"
    with pytest.raises(mca.Error, match="both given"):
        mca.Heterogeneity(preset="low", shares=(0, 0, 0, 1))


def test_copy_deepcopy_and_pickle():
    """copy.copy, copy.deepcopy and pickle (a process pool's workers get their scene pickled) raised
    "cannot pickle 'mca._mca.Scene' object"; each is deep, and pickling checks the scene where it is made."""
    import copy
    import pickle
    scene = mca.Scene.default()
    scene.solver.spacing = 0.1
    pickled = [pickle.loads(pickle.dumps(scene, protocol)) for protocol in range(pickle.HIGHEST_PROTOCOL + 1)]
    for other in [copy.copy(scene), copy.deepcopy(scene)] + pickled:  # (protocols 0 and 1 aborted the process)
        # (A pickled scene changed from Python is read back under a source that says so.)
        assert other == scene and other.source in (scene.source, scene.source + " (as changed from Python)")
        other.objects[0].size = (3, 3, 3)
        assert scene.objects[0].size != (3, 3, 3)
    nested = copy.deepcopy({"a": [scene, scene]})
    assert nested["a"][0] == scene
    with pytest.raises(mca.Error, match="no objects"):
        pickle.dumps(mca.Scene("empty"))
    # A mesh that is not there is refused where the scene is pickled, not where it is read.
    moved = mca.Scene.default()
    moved.add_object(name="gone", shape="mesh", mesh="/nonexistent/cow.off", position=(0, 3, 1))
    with pytest.raises(mca.Error, match="cow.off"):
        pickle.dumps(moved)


def test_a_relative_mesh_path_is_taken_from_the_folder_current_when_set(tmp_path, monkeypatch):
    """A relative mesh path set from Python was resolved when the Simulation was built, from whatever folder
    was current then (a script that changed folder lost its mesh); a scene file's are resolved when read."""
    (tmp_path / "cube.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n")
    monkeypatch.chdir(tmp_path)
    scene = mca.Scene("meshes")
    scene.add_object(shape="mesh", mesh="cube.obj", fit_size=0.2, position=(0, 0, 0.2))
    region = mca.Region(shape="mesh", mesh=pathlib.Path("cube.obj"), material="glass")
    assert scene.objects[0].mesh == region.mesh == str(tmp_path / "cube.obj")
    monkeypatch.chdir("/")
    assert mca.Simulation(scene, threads=1).automata > 0


def test_messages_of_a_scene_changed_from_python_say_so():
    """A scene read from a file and changed here was reported as the file ("<built-in>/wall_ball.toml:
    projectile[0].position = ..." for a position the file does not hold)."""
    scene = mca.Scene.default()
    assert mca.Simulation(scene, threads=1).scene.source == "<built-in>/wall_ball.toml"
    scene.projectiles[0].position = (0, 0, 0.75)  # inside the wall
    with pytest.raises(mca.Error, match=r"^<built-in>/wall_ball\.toml \(as changed from Python\): projectile\[0\]"):
        mca.Simulation(scene, threads=1)
    with pytest.raises(mca.Error, match=r"^<built-in>/wall_ball\.toml \(as changed from Python\): projectile"):
        mca.Simulation(scene.copy().copy(), threads=1)  # (said once)


def test_save_and_load(tmp_path):
    scene = mca.Scene.default()
    scene.output.duration = 0.01
    scene.save(tmp_path / "s.toml")
    again = mca.Scene.load(tmp_path / "s.toml")
    assert again == scene and again.source == str(tmp_path / "s.toml")
    # Written to a temporary name and renamed, as a file written in place would be: through a link to the
    # file it names (the link stays), and with the mode the file had (a 0600 scene became 0644).
    import os
    (tmp_path / "target.toml").write_text("old\n")
    (tmp_path / "link.toml").symlink_to("target.toml")
    scene.save(tmp_path / "link.toml")
    assert (tmp_path / "link.toml").is_symlink() and mca.Scene.load(tmp_path / "target.toml") == scene
    os.chmod(tmp_path / "s.toml", 0o600)
    scene.save(tmp_path / "s.toml")
    assert os.stat(tmp_path / "s.toml").st_mode & 0o777 == 0o600
