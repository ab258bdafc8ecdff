"""Checks that run inside Blender (blender -b --factory-startup --python in_blender.py -- CASE ARGS...).

Run by test_blender.py, which makes the run folders with the built mca. Exit code 0 when every check
holds; a failed check prints `FAIL: ...` and exits 1.
"""

import os
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
if "install" not in sys.argv:  # the install case must find the installed copy only
    sys.path.insert(0, os.path.dirname(HERE))  # blender/: the add-on's package

import bpy  # noqa: E402
import numpy as np  # noqa: E402

failures = []


def check(cond, what):
    print(("ok: " if cond else "FAIL: ") + what)
    if not cond:
        failures.append(what)


def clear():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def evaluated_points(obj, frame):
    bpy.context.scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(dg).to_mesh()
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    faces = len(mesh.polygons)
    obj.evaluated_get(dg).to_mesh_clear()
    return co.reshape(-1, 3) @ np.array(obj.matrix_world.to_3x3()).T.astype(np.float32) + \
        np.array(obj.matrix_world.translation, np.float32), faces


def pvd_frames(run_dir):
    from io_import_mca import reader
    return len(reader.read_pvd(os.path.join(run_dir, "automata.pvd")))


def import_checks(run_dir, surface):
    """Imports a run and checks what it made."""
    from io_import_mca import build
    clear()
    # A material of the user's that happens to be named as the importer's is left alone.
    own = bpy.data.materials.new("mca colour")
    own.diffuse_color = (0.1, 0.2, 0.3, 1.0)
    t0 = time.perf_counter()
    result = build.import_run(bpy.context, run_dir)
    seconds = time.perf_counter() - t0
    used = {s.material for o in bpy.data.objects if o.type == "MESH" for s in o.material_slots if s.material}
    check(own not in used and max(abs(a - b) for a, b in zip(own.diffuse_color, (0.1, 0.2, 0.3, 1.0))) < 1e-6 and
          not own.get("mca_colour_material"),
          f"the user's own 'mca colour' is left alone (the import uses {sorted(m.name for m in used)})")
    print(f"import: {result.frames} frames in {seconds:.2f} s")
    scene = bpy.context.scene
    frames = pvd_frames(run_dir)
    check(result.frames == frames, f"{result.frames} frames imported, automata.pvd lists {frames}")
    check(scene.frame_start == 0 and scene.frame_end == frames - 1,
          f"the timeline is frames 0 to {frames - 1} ({scene.frame_start} to {scene.frame_end})")
    fps = scene.render.fps / scene.render.fps_base
    check(abs(fps - result.run.fps) < 1e-6 and 10 <= fps <= 30, f"{fps:g} frames/s, the run's {result.run.fps:g}")
    names = sorted(o.name for o in result.collection.all_objects)
    print("objects:", [n for n in names if not n.startswith(("mca automata ", "mca surface "))], "and", frames,
          "frames")
    main = "mca surface" if surface else "mca automata"
    check(result.automata.name == main, f"the automata are '{result.automata.name}', expected '{main}'")
    check(len(result.frame_objects) == frames and
          all(o.name == f"{main} {k:06d}" for k, o in enumerate(result.frame_objects)),
          f"an object per frame: {len(result.frame_objects)}")
    # Each frame shows its own object only, in the viewport and in renders.
    wrong = []
    for k in range(frames):
        scene.frame_set(k)
        shown = [j for j, o in enumerate(result.frame_objects) if not o.hide_viewport]
        rendered = [j for j, o in enumerate(result.frame_objects) if not o.hide_render]
        if shown != [k] or rendered != [k]:
            wrong.append((k, shown, rendered))
    check(not wrong, f"each frame shows its object only (wrong: {wrong[:3]})")
    balls = len(result.run.projectiles[0][0]) if result.run.projectiles else 0
    check(len(result.projectiles) == balls == 1, f"{len(result.projectiles)} projectile spheres for {balls} balls")
    check(result.ground is not None and result.camera is not None and scene.camera == result.camera,
          "a ground plane and the scene's camera")
    check(result.light is not None and result.light.type == "LIGHT", "a sun light for Eevee and Cycles")
    # Beside a bound surface, the objects it does not carry (the surface scene's block) are cubes, as the
    # renderer draws them: they were left out.
    if surface:
        unbound = result.run.unbound_automata()
        check(unbound is not None and 0 < unbound.sum() < len(unbound), f"{int(unbound.sum())} automata of the block")
        check(result.cubes is not None and result.cubes.name == "mca automata" and
              [o.name for o in result.cube_objects] == [f"mca automata {k:06d}" for k in range(frames)],
              f"the block's cubes: an object per frame ({len(result.cube_objects)})")
        shown = int((result.run.exposed()[0] & unbound).sum())
        _, cube_faces = evaluated_points(result.cube_objects[0], 0)
        check(shown > 0 and cube_faces == 6 * shown, f"frame 0: {cube_faces} faces = 6 x {shown} cubes of the block")
        for k in (0, frames - 1):
            scene.frame_set(k)
            check([j for j, o in enumerate(result.cube_objects) if not o.hide_render] == [k],
                  f"frame {k} shows its cubes only")
    else:
        check(result.cubes is None and not result.cube_objects, "no other cubes")
    expected = frames + balls + 3 + len(result.fragments) + len(result.cube_objects)
    check(len(names) == expected, f"{len(names)} objects, expected {expected}")

    # The automata move between frames, and each frame shows only its own.
    first, faces0 = evaluated_points(result.frame_objects[0], 0)
    last, faces1 = evaluated_points(result.frame_objects[-1], frames - 1)
    check(faces0 > 0 and faces1 > 0, f"faces at the first and last frame: {faces0}, {faces1}")
    lo0, hi0 = first.min(axis=0), first.max(axis=0)
    lo1, hi1 = last.min(axis=0), last.max(axis=0)
    moved = float(np.abs(np.concatenate([lo1 - lo0, hi1 - hi0])).max())
    check(moved > result.run.spacing, f"the surface's box moves by {moved:.3f} m between the first and last frame")
    if not surface:
        shown = int(result.run.exposed()[0].sum())
        check(faces0 == 6 * shown, f"frame 0: {faces0} faces = 6 x {shown} exposed automata")
        # frame 0's box is the automata's box and a half cube around it
        pts0 = result.run.frames[0]["points"]
        err = float(np.abs(lo0 - (pts0.min(axis=0) - result.run.spacing / 2)).max())
        check(err < 1e-4, f"frame 0's cubes span the automata's box (off by {err:.2e} m)")
    ball = result.projectiles[0]
    scene.frame_set(0)
    b0 = np.array(ball.matrix_world.translation)
    scene.frame_set(frames - 1)
    b1 = np.array(ball.matrix_world.translation)
    want = result.run.projectiles[-1][0][0]
    check(np.abs(b1 - want).max() < 1e-4 and np.linalg.norm(b1 - b0) > 0.05,
          f"the ball moves from {b0.round(3)} to {b1.round(3)} (the run: {want.round(3)})")
    # Colours: the renderer's fragment colours on the mesh, grey for the main body.
    colours = result.frame_objects[0].data.color_attributes.get("mca_colour")
    check(colours is not None, "the colour attribute mca_colour")
    return result, seconds


def case_import(run_dir, surface=False, limit=None):
    result, seconds = import_checks(run_dir, surface)
    if limit is not None:
        check(seconds < limit, f"the import took {seconds:.2f} s, under {limit} s")
        # Playback: switching to each frame (its object's evaluation) within the time a frame is shown at the
        # run's rate (drawing it is the viewport's, not measured here). The first pass evaluates each frame's
        # object; the second, as a viewport plays the timeline in a loop, finds them evaluated.
        scene = bpy.context.scene
        passes = []
        for _ in range(2):
            t0 = time.perf_counter()
            for k in range(scene.frame_start, scene.frame_end + 1):
                scene.frame_set(k)
                bpy.context.evaluated_depsgraph_get()
            passes.append((time.perf_counter() - t0) / result.frames)
        per_frame = passes[1]
        check(per_frame < 1.0 / result.run.fps,
              f"a frame in {1000 * per_frame:.2f} ms (the first pass {1000 * passes[0]:.1f} ms), under the "
              f"{1000 / result.run.fps:.0f} ms a frame is shown at {result.run.fps:g} frames/s")
    if surface:
        check(len(result.fragments) == len(result.run.fragment_files) > 0,
              f"{len(result.fragments)} fragment mesh objects for {len(result.run.fragment_files)} files")
        for obj in result.fragments:
            check(len(obj.data.polygons) > 0, f"{obj.name} has {len(obj.data.polygons)} faces")


def case_alembic(run_dir, abc):
    """The .abc written by mca_cli.py (on a Blender with Alembic), re-imported: an object per frame, each
    with its frame's cubes, which move from the first frame to the last."""
    clear()
    bpy.ops.wm.alembic_import(filepath=abc)
    objects = {o.name: o for o in bpy.data.objects}
    frames = pvd_frames(run_dir)
    automata = sorted((n for n in objects if n.startswith("mca automata")))
    print("alembic objects:", len(objects), automata[:2], "...")
    check(len(automata) == frames, f"{len(automata)} frame objects came back, {frames} frames")
    check(any(n.startswith("mca projectile") for n in objects), "the projectile came back")
    check(any(o.type == "CAMERA" for o in objects.values()), "the camera came back")
    if len(automata) != frames:
        return
    from io_import_mca import reader
    run = reader.Run(run_dir)
    exposed = run.exposed()
    for k in (0, frames - 1):
        pts, faces = evaluated_points(objects[automata[k]], k)
        check(faces == 6 * int(exposed[k].sum()), f"frame {k}: {faces} faces, 6 per exposed automaton")
        want = run.frames[k]["points"][exposed[k]]
        err = float(np.abs(np.concatenate([pts.min(axis=0) - want.min(axis=0), pts.max(axis=0) - want.max(axis=0)])).max())
        check(err < run.spacing, f"frame {k}: the cubes' box is the automata's within {err:.3f} m")


def case_blend(run_dir, blend):
    """The .blend of mca_cli.py --frames 3, opened without the add-on: three frames' objects, each shown at
    its frame, the timeline 0 to 2, the camera, and the cubes where the run has its automata."""
    bpy.ops.wm.open_mainfile(filepath=blend)
    check("io_import_mca" not in sys.modules, "the add-on is not loaded")
    scene = bpy.context.scene
    objs = sorted((o for o in bpy.data.objects if o.name.startswith("mca automata ")), key=lambda o: o.name)
    check(len(objs) == 3 and scene.frame_start == 0 and scene.frame_end == 2,
          f"3 frames' objects ({len(objs)}), the timeline {scene.frame_start} to {scene.frame_end}")
    check(scene.camera is not None and scene.camera.name == "mca camera", "the run's camera is the scene's")
    from io_import_mca import reader
    run = reader.Run(run_dir, max_frames=3)
    exposed = run.exposed()
    for k, obj in enumerate(objs):
        scene.frame_set(k)
        shown = [o.name for o in objs if not o.hide_viewport and not o.hide_render]
        check(shown == [obj.name], f"frame {k} shows {shown}")
        pts, faces = evaluated_points(obj, k)
        check(faces == 6 * int(exposed[k].sum()), f"frame {k}: {faces} faces, 6 per exposed automaton")


def case_obj_sequence(run_dir, folder):
    """The OBJ files of mca_cli.py, read back by Blender's OBJ importer: each frame's file holds that frame's
    cubes (6 faces per exposed automaton, with the ball's) where the run has its automata."""
    from io_import_mca import reader
    run = reader.Run(run_dir)
    exposed = run.exposed()
    for k in range(len(run.frames)):
        clear()
        bpy.ops.wm.obj_import(filepath=os.path.join(folder, f"short{k}.obj"))
        meshes = [o for o in bpy.data.objects if o.type == "MESH"]
        automata = [o for o in meshes if o.name.startswith("mca_automata")]  # the OBJ names have no spaces
        check(len(automata) == 1 and len(meshes) == 2 and automata[0].name == f"mca_automata_{k:06d}",
              f"frame {k}: the frame's automata and the ball ({[o.name for o in meshes]})")
        if len(automata) != 1:
            return
        mesh = automata[0].data
        shown = int(exposed[k].sum())
        check(len(mesh.polygons) == 6 * shown, f"frame {k}: {len(mesh.polygons)} faces = 6 x {shown} exposed automata")
        co = np.empty(3 * len(mesh.vertices), np.float32)
        mesh.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3) @ np.array(automata[0].matrix_world.to_3x3()).T
        pts = run.frames[k]["points"][exposed[k]]
        err = float(np.abs(np.concatenate([co.min(axis=0) - pts.min(axis=0), co.max(axis=0) - pts.max(axis=0)])).max())
        check(err < run.spacing, f"frame {k}: the cubes' box is the automata's within {err:.3f} m")
        check(mesh.color_attributes.get("Color") is not None or len(mesh.color_attributes) > 0,
              f"frame {k}: the colours came with the vertices")


def case_bad_input(case_dir):
    """Each broken folder under case_dir: the operator reports an error (no traceback), as the report area
    shows it."""
    import io_import_mca
    from io_import_mca import reader
    io_import_mca.register()
    expect = {
        "no_frames": "holds no frames",
        "empty_pvd": "lists no frames",
        "missing_frame": "is missing",
        "cut_short": "cut short",
        "newer_vtu": "newer mca",
        "newer_pvd": "newer mca",
        "not_a_run": "not an mca run folder",
        "bad_summary": "not complete JSON",
        "mixed_frames": "frames of different runs",
        "summary_list": "summary.json is not the summary mca writes",
        "gravity_string": "scene.toml: [solver] gravity = 'down' is not a vector of 3 numbers",
        "ground_number": "scene.toml: ground = 5 is not a table",
        "fov_string": "scene.toml: [camera] fov = 'wide' is not a number of degrees",
        "fov_zero": "scene.toml: [camera] fov = 0.0 is not a number of degrees",
        "frames_file": "a folder on its path is a file",
        "frame_folder": "automata_000001.vtu is a folder",
        "fragment_huge": "automata_000002.vtu: array 'fragment' holds 2147483647 at automaton 5, outside 0..",
        "object_negative": "automata_000002.vtu: array 'object' holds -1 at automaton 5, outside 0..",
        "does_not_exist": os.path.join(case_dir, "does_not_exist") + " does not exist",
        "frame_fifo": "automata_000001.vtu is a FIFO (named pipe), not a file of the run",
        "frame_dev_zero": "automata_000001.vtu is a character device, not a file of the run",
        "projectiles_fifo": "projectiles.pvd is a FIFO (named pipe), not a file of the run",
        "pvd_absolute": "a DataSet's file '/etc/passwd' lies outside the run folder",
        "pvd_dot_dot": "a DataSet's file '../short/frames/automata_000001.vtu' lies outside the run folder",
        "nan_points": "at point 7: mca writes finite values only; the file is damaged",
        "fragment_float": "automata_000002.vtu: array 'fragment' is of float32, not the integers mca writes",
        "no_offset": "automata_000002.vtu is cut short or damaged (KeyError: 'offset')",
        "frame_sparse": "automata_000001.vtu is cut short or not a VTK file written by mca (no appended data in its "
                        "first MB)",
    }
    for name, words in expect.items():
        path = os.path.join(case_dir, name)
        try:
            bpy.ops.import_scene.mca_run(directory=path + "/")
            check(False, f"{name}: the import was refused")
        except RuntimeError as e:
            message = str(e)
            print(f"{name}: {message.strip()}")
            check(words in message and "Traceback" not in message, f"{name}: the report says '{words}'")
    # A run folder with no summary.json (a run still going, or killed) imports, with a warning.
    reader.Run(os.path.join(case_dir, "no_summary"))
    warnings = reader.Run(os.path.join(case_dir, "no_summary")).warnings
    check(any("still going or was killed" in w for w in warnings), f"no_summary: warned: {warnings}")
    # Render options that would divide by zero: the defaults, warned; a run without its balls' collection (the
    # scene has a ball): imported without balls, warned.
    for name, words in (("render_zero", "render.json is not the render options mca writes"),
                        ("no_projectiles", "projectiles.pvd is missing, though the scene has 1 projectile"),
                        ("projectiles_behind", "(the run is still writing): importing the first")):
        try:
            bpy.ops.import_scene.mca_run(directory=os.path.join(case_dir, name) + "/")
        except RuntimeError as e:
            check(False, f"{name} imports ({str(e).strip()})")
            continue
        warnings = reader.Run(os.path.join(case_dir, name)).warnings
        check(any(words in w for w in warnings), f"{name}: warned '{words}': {warnings}")
    # A failure nobody foresaw (the reader made to fail): one line in the report area naming the run folder.
    real = reader.Run

    def fail(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")
    reader.Run = fail
    try:
        bpy.ops.import_scene.mca_run(directory=os.path.join(case_dir, "no_summary") + "/")
        check(False, "the unforeseen failure was refused")
    except RuntimeError as e:
        message = str(e)
        print(f"unforeseen failure: {message.strip()}")
        check("ZeroDivisionError" in message and os.path.join(case_dir, "no_summary") in message and
              "Traceback" not in message and len(message.strip().splitlines()) == 1,
              "an unforeseen failure is one line naming the run folder")
    finally:
        reader.Run = real
    # A failure while building (the fragment meshes, after the frames' objects are made) takes back what the
    # import made and set: a second try made .001 copies beside the first's leftovers.
    from io_import_mca import build
    kinds = ("objects", "collections", "meshes", "materials", "node_groups", "cameras", "lights", "actions")
    before = {k: sorted(d.name for d in getattr(bpy.data, k)) for k in kinds}
    scene = bpy.context.scene
    settings = (scene.frame_start, scene.frame_end, scene.render.fps, scene.camera)
    real_fragments = build._fragment_meshes

    def fail_late(*args, **kwargs):
        check(bpy.data.objects.get("mca automata 000000") is not None, "the frames were built before the failure")
        raise ZeroDivisionError("float division by zero")
    build._fragment_meshes = fail_late
    try:
        for attempt in range(2):
            try:
                bpy.ops.import_scene.mca_run(directory=os.path.join(case_dir, "no_summary") + "/")
                check(False, "the failure while building was refused")
            except RuntimeError as e:
                check("ZeroDivisionError" in str(e), f"the failure while building is reported ({str(e).strip()})")
            after = {k: sorted(d.name for d in getattr(bpy.data, k)) for k in kinds}
            check(after == before, f"a failed import (try {attempt + 1}) leaves the data as it was: "
                                   f"{ {k: sorted(set(after[k]) - set(before[k])) for k in kinds} }")
            check((scene.frame_start, scene.frame_end, scene.render.fps, scene.camera) == settings,
                  "a failed import leaves the scene's settings as they were")
    finally:
        build._fragment_meshes = real_fragments


def case_missing_numpy(run_dir):
    """Without numpy the add-on still registers, and the import says what is missing."""
    for name in [m for m in sys.modules if m == "numpy" or m.startswith("numpy.") or m.startswith("io_import_mca")]:
        del sys.modules[name]
    sys.modules["numpy"] = None  # `import numpy` now raises ImportError
    import io_import_mca
    io_import_mca.register()
    try:
        bpy.ops.import_scene.mca_run(directory=run_dir + "/")
        check(False, "the import without numpy was refused")
    except RuntimeError as e:
        print("report:", str(e).strip())
        check("needs numpy" in str(e) and "python3-numpy" in str(e) and "Traceback" not in str(e),
              "the report names numpy and its package")


def case_install(zip_path, run_dir):
    """The add-on installed from its .zip (into BLENDER_USER_SCRIPTS, set by the caller) and enabled: the
    menu entry and the operator work."""
    bpy.ops.preferences.addon_install(filepath=zip_path)
    bpy.ops.preferences.addon_enable(module="io_import_mca")
    import addon_utils
    check(addon_utils.check("io_import_mca")[1], "io_import_mca is enabled")
    import io_import_mca
    check(os.path.realpath(io_import_mca.__file__).startswith(os.path.realpath(os.environ["BLENDER_USER_SCRIPTS"])),
          f"it runs from the installed copy ({io_import_mca.__file__})")
    check(any(getattr(f, "__name__", "") == "menu_import" for f in bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize()),
          "File > Import has the mca run entry")
    bpy.ops.import_scene.mca_run(directory=run_dir + "/")
    check(bpy.data.objects.get("mca automata 000000") is not None, "the operator imported the run")


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    case = args[0]
    if case == "import":
        case_import(args[1], limit=float(args[2]) if len(args) > 2 else None)
    elif case == "surface":
        case_import(args[1], surface=True)
    elif case == "alembic":
        case_alembic(args[1], args[2])
    elif case == "blend":
        case_blend(args[1], args[2])
    elif case == "obj_sequence":
        case_obj_sequence(args[1], args[2])
    elif case == "bad_input":
        case_bad_input(args[1])
    elif case == "missing_numpy":
        case_missing_numpy(args[1])
    elif case == "install":
        case_install(args[1], args[2])
    else:
        raise SystemExit(f"unknown case {case}")


if __name__ == "__main__":
    try:
        main()
    except Exception:  # noqa: BLE001
        traceback.print_exc()
        failures.append("an exception")
    print("FAILED: " + "; ".join(failures) if failures else "PASSED")
    sys.stdout.flush()
    os._exit(1 if failures else 0)
