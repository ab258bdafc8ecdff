"""Bad scenes and bad calls raise mca.Error with the command's message: the file, the key, the value and
the fix."""
import pytest

import mca


def test_bad_scene_file_names_file_and_key(tmp_path, mca_binary):
    import subprocess

    path = tmp_path / "bad.toml"
    path.write_text(mca.Scene.default().to_toml().replace("spacing = 0.05", "spacing = -0.05"))
    with pytest.raises(mca.Error) as e:
        mca.Scene.load(path)
    message = str(e.value)
    assert str(path) in message and "solver.spacing" in message and "-0.05" in message
    # The command prints the same message.
    r = subprocess.run([str(mca_binary), "info", str(path)], capture_output=True, text=True)
    assert r.returncode != 0 and message in r.stderr


def test_syntax_error_and_unknown_key_name_the_line():
    with pytest.raises(mca.Error, match=r"^s\.toml:2:\d+: TOML syntax error"):
        mca.Scene.from_toml('name = "x"\n[solver\n', "s.toml")
    with pytest.raises(mca.Error, match=r"s\.toml:2.*spacng.*did you mean 'spacing'"):
        mca.Scene.from_toml("[solver]\nspacng = 0.1\n", "s.toml")


def test_missing_file():
    with pytest.raises(mca.Error, match="nowhere.toml: scene file not found"):
        mca.Scene.load("nowhere.toml")


def test_python_built_scene_is_validated_by_the_same_code():
    scene = mca.Scene.default()
    scene.solver.safety = 1.5
    # The same message as the same value in a file, with the scene's source for the file.
    text = scene.to_toml()
    with pytest.raises(mca.Error) as from_file:
        mca.Scene.from_toml(text, scene.source)
    with pytest.raises(mca.Error) as validated:
        scene.validate()
    with pytest.raises(mca.Error) as built:
        mca.Simulation(scene)
    # (Changed from Python after it was read: the messages say so, where the file's names the file.)
    changed = str(from_file.value).replace(scene.source + ":", scene.source + " (as changed from Python):", 1)
    assert str(validated.value) == str(built.value) == changed != str(from_file.value)
    assert "solver.safety = 1.5 is out of range" in str(validated.value)

    scene = mca.Scene.default()
    scene.objects[0].material = "concret"
    with pytest.raises(mca.Error, match=r"object\[0\]\.material.*concret"):
        scene.validate()


def test_keys_and_values_checked_when_set():
    scene = mca.Scene()
    with pytest.raises(mca.Error, match=r"'sise' is not a key of \[\[object\]\]; did you mean 'size'"):
        scene.add_object(sise=(1, 1, 1))
    with pytest.raises(mca.Error, match=r'object\.shape = "cube" is not a shape'):
        scene.add_object(shape="cube")
    with pytest.raises(mca.Error, match=r"object\.size = .* is not three numbers"):
        mca.Object(size=(1, 2))
    with pytest.raises(mca.Error, match=r'heterogeneity\.preset = "mediun" is not a preset; did you mean \'medium\''):
        scene.heterogeneity.preset = "mediun"
    with pytest.raises(mca.Error, match="not a built-in material"):
        mca.Material.builtin("steal")
    with pytest.raises(mca.Error, match=r"scene\.objects\[0\] is a str, not an mca\.Object"):
        scene.objects.append("wall")
        scene.validate()
    with pytest.raises(AttributeError):
        mca.Solver().spacng = 0.1


def test_bad_simulation_arguments():
    scene = mca.Scene.default()
    with pytest.raises(mca.Error, match='Simulation: backend = "gpu" is not a backend; .*use "auto", "cpu", "cuda" or "cuda-emulation"'):
        mca.Simulation(scene, backend="gpu")
    with pytest.raises(mca.Error, match="did you mean 'cpu'"):
        mca.Simulation(scene, backend="CPU")
    with pytest.raises(mca.Error, match="^threads=-1 is negative"):
        mca.Simulation(scene, threads=-1)
    with pytest.raises(mca.Error, match="the scene has no objects"):
        mca.Simulation(mca.Scene())
    sim = mca.Simulation(scene, threads=1)
    with pytest.raises(mca.Error, match="negative"):
        sim.advance(-1)
    with pytest.raises(mca.Error, match="not a colour mode"):
        mca.render(sim, colour="rainbow")
    with pytest.raises(mca.Error, match='draw "surface" needs an object of shape "mesh"'):
        mca.render(sim, draw="surface")


def test_time_step_above_the_critical_one_is_refused():
    scene = mca.Scene.default()
    sim = mca.Simulation(scene, threads=1)
    scene.solver.time_step = sim.time_step * 6
    with pytest.raises(mca.Error, match="solver.time_step"):
        mca.Simulation(scene)


def test_duplicate_names_are_refused_when_added():
    scene = mca.Scene()
    scene.add_material("weak", base="concrete", tensile_strength=1e6)
    with pytest.raises(mca.Error, match=r'add_material: scene\.materials\[0\] is named "weak" already'):
        scene.add_material("weak", base="glass")
    assert [m.name for m in scene.materials] == ["weak"]
    scene.add_object(name="wall")
    with pytest.raises(mca.Error, match=r'add_object: scene\.objects\[0\] is named "wall" already'):
        scene.add_object(name="wall", position=(0, 2, 0))
    scene.add_object()  # named object1 by its index
    with pytest.raises(mca.Error, match=r'scene\.objects\[1\] is named "object1" already'):
        scene.add_object(name="object1")
    assert [o.name for o in scene.objects] == ["wall", "object1"]
    scene.validate()


def test_progress_must_be_callable_before_any_step():
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    with pytest.raises(mca.Error, match=r"progress = 3 is not callable; give a function progress\(done, total\) or None"):
        sim.advance(5, progress=3)
    with pytest.raises(mca.Error, match="progress = 'x' is not callable"):
        sim.advance_to(0.001, progress="x")
    assert sim.step == 0


def test_a_simulation_advancing_refuses_reads_and_its_repr_says_so():
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    seen = []

    def progress(done, total):
        seen.append(repr(sim))
        with pytest.raises(mca.Error, match="the simulation is advancing"):
            sim.positions()

    sim.advance(300, progress=progress)
    assert seen and all("advancing" in r and '"wall_ball"' in r for r in seen), seen
    assert "advancing" not in repr(sim) and "step 300" in repr(sim)


def test_backend_keyword(tmp_path):
    scene = mca.Scene.default()
    cpu = mca.Simulation(scene, threads=1, backend="cpu")
    emulated = mca.Simulation(scene, backend="cuda-emulation")
    assert cpu.backend.startswith("cpu") and emulated.backend == "cuda-emulation"
    cpu.advance(40)
    emulated.advance(40)
    assert emulated.state_hash() == cpu.state_hash()
    # None (the default): the scene's own solver.backend.
    scene.solver.backend = "cuda-emulation"
    assert mca.Simulation(scene).backend == "cuda-emulation"
    assert mca.Simulation(scene, backend="cpu").backend.startswith("cpu")
    # A checkpoint continues on any backend with the same bits.
    path = tmp_path / "at40.mcack"
    cpu.checkpoint(str(path))
    cpu.advance(30)
    resumed = mca.Simulation.resume(path, backend="cuda-emulation")
    assert resumed.backend == "cuda-emulation"
    resumed.advance(30)
    assert resumed.state_hash() == cpu.state_hash()
    # cuda runs where there is a GPU, and says why not where there is none.
    try:
        assert mca.Simulation(scene, backend="cuda").backend.startswith("cuda (")
    except mca.Error as e:
        assert str(e).startswith('Simulation: backend = "cuda": ') and "NVIDIA" in str(e)
    try:
        assert mca.Simulation.resume(path, backend="cuda").backend.startswith("cuda (")
    except mca.Error as e:
        assert str(e).startswith('Simulation.resume: backend = "cuda": ') and "NVIDIA" in str(e)


def test_a_simulation_stopped_by_a_full_gpu_refuses_and_touches_no_folder(tmp_path, monkeypatch):
    # The emulation plays a GPU of 10 MB: the default wall's arrays take 8.6 MB, and the first energy
    # check's (step 256) 3 MB more (CudaEmulation.AFullGpuStopsARunWhichResumesOnTheCpuWithTheSameBits).
    scene = mca.Scene.default()
    keep = tmp_path / "keep"
    cpu = mca.Simulation(scene, threads=1, backend="cpu")
    for _ in range(2):
        cpu.write_frame(keep)
        cpu.advance(10)
    cpu.close_output()
    listing = sorted(str(p.relative_to(keep)) for p in keep.rglob("*"))
    monkeypatch.setenv("MCA_EMULATED_GPU_MEMORY_MB", "10")
    sim = mca.Simulation(scene, backend="cuda-emulation")
    with pytest.raises(mca.Error, match=r"^the GPU's memory is full: .*use backend \"cpu\""):
        sim.advance(300)
    assert sim.step == 256 and sim.time == 256 * sim.time_step
    assert "step 256" in repr(sim) and "stopped" in repr(sim) and "stopped" not in repr(cpu)
    stopped = r"^this simulation stopped at step 256, computing its energies: .*the GPU's memory is full"
    for call in (lambda: sim.advance(1), lambda: sim.advance(0), lambda: sim.advance_to(0.0), sim.positions, sim.state_hash, lambda: sim.write_frame(keep),
                 lambda: sim.checkpoint(tmp_path / "x.mcack"), lambda: mca.render(sim)):
        with pytest.raises(mca.Error, match=stopped):
            call()
    assert sorted(str(p.relative_to(keep)) for p in keep.rglob("*")) == listing
    assert not (tmp_path / "x.mcack").exists()
    # A state saved before continues on the CPU.
    monkeypatch.delenv("MCA_EMULATED_GPU_MEMORY_MB")
    fresh = mca.Simulation(scene, backend="cuda-emulation")
    fresh.advance(20)
    assert fresh.state_hash() == cpu.state_hash()


def test_write_frame_into_a_folder_whose_frames_folder_is_a_file(tmp_path):
    # A file named `frames` gave a bare RuntimeError (a filesystem error); it is mca.Error, naming it and
    # the fix, before anything is written.
    out = tmp_path / "out"
    out.mkdir()
    (out / "frames").write_text("x\n")
    sim = mca.Simulation(mca.Scene.default(), threads=1, backend="cpu")
    with pytest.raises(mca.Error, match=r"frames' is there and is not a folder: the run writes the VTK frames"):
        sim.write_frame(out)
    assert sorted(p.name for p in out.iterdir()) == ["frames"]
    (out / "frames").unlink()
    assert sim.write_frame(out) == 0


def test_write_frame_into_a_folder_with_a_folder_at_a_frames_name(tmp_path):
    # A folder where a later frame goes stopped the writes only at that frame; it is refused at the first.
    out = tmp_path / "out"
    (out / "frames" / "automata_000007.vtu" / "mine").mkdir(parents=True)
    sim = mca.Simulation(mca.Scene.default(), threads=1, backend="cpu")
    with pytest.raises(mca.Error, match=r"automata_000007.vtu' is a folder at the name of a file a run writes"):
        sim.write_frame(out)
    assert (out / "frames" / "automata_000007.vtu" / "mine").is_dir()
    assert sorted(p.name for p in out.iterdir()) == ["frames"]


def test_a_path_with_a_nul_character_is_refused(tmp_path, monkeypatch):
    """The system ends a name at a NUL: "notes.txt\\0.mcack" wrote the checkpoint over notes.txt, a scene was
    saved to and loaded from the name before the NUL, a frame folder's "\\0/../.." was cut off (a hostile
    review, 2026-12-06). Every path is refused as open() refuses it; so is a mesh path holding one."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("mine\n")
    scene = mca.Scene.default()
    sim = mca.Simulation(scene, threads=1)
    for call in (lambda: sim.checkpoint("notes.txt\0.mcack"), lambda: scene.save("notes.txt\0.toml"),
                 lambda: mca.Scene.load("notes.txt\0.toml"), lambda: sim.write_frame("out\0/../elsewhere"),
                 lambda: mca.Simulation.resume("notes.txt\0.mcack"), lambda: mca.render(sim, "p.png\0.txt")):
        with pytest.raises(mca.Error, match="holds a NUL character"):
            call()
    assert (tmp_path / "notes.txt").read_text() == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    scene.objects[0].shape = "mesh"
    # (Refused when set: a mesh path set from Python is resolved then, as a scene file's is when read.)
    with pytest.raises(mca.Error, match=r"object.mesh = .* holds a NUL character"):
        scene.objects[0].mesh = "x.obj\0.stl"


def test_values_past_every_range_are_named_as_given(tmp_path):
    """A position of 1e308 was "inf m from the origin" (its square overflowed), the ground's height was shown as
    a vector, and a render size of a numpy array of no dimension raised a bare TypeError (a hostile review,
    2026-12-06)."""
    scene = mca.Scene.default()
    scene.objects[0].position = (1e308, 0, 0)
    with pytest.raises(mca.Error, match=r"object\[0\].position = \[1e308, 0, 0\] is 1e308 m from the origin"):
        mca.Simulation(scene, threads=1)
    scene = mca.Scene.default()
    scene.ground.height = 1e300
    with pytest.raises(mca.Error, match=r"ground.height = 1e300 is more than 1e6 m from the origin"):
        mca.Simulation(scene, threads=1)
    import numpy as np
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    for size in (np.array(3), np.array([3]), 3):
        with pytest.raises(mca.Error, match="render: size = .* is not two whole numbers"):
            mca.render(sim, size=size)
