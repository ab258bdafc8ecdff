"""mca runs in Blender from the command line:

    blender -b --factory-startup --python blender/mca_cli.py -- RUN_DIR OUT [options]

OUT.abc   an Alembic cache of the whole run through Blender's exporter (the automata or surface, the
          projectiles, the camera, the ground) for Houdini, Maya, Unreal. Needs a Blender built with Alembic
          (bpy.app.alembic.supported: blender.org's builds); Debian's blender 3.4.1 is built without it, and
          the script says so and exits with 1;
OUT.obj   the automata (or surface) and the projectiles of every frame through Blender's OBJ exporter, a file
          per frame (OUT0.obj, OUT1.obj, ...: the name with the frame number; y up as OBJ readers expect, the
          colours as vertex colours), which every Blender can write;
OUT.png   one frame (the last one, or --frame N) rendered with the Workbench (--engine workbench, the
          default: a few seconds), Eevee (--engine eevee: 15 s to a minute on 2 CPU cores, most of it
          compiling its shaders) or Cycles on the CPU (--engine cycles, --samples N);
OUT.blend the scene saved as a .blend.

Options: --frame N (the frame of a .png; default: the last), --frames N (import only the first N frames),
--size WxH (the picture's size; default: the run's render size, 1280x720), --engine workbench|eevee|cycles,
--samples N (anti-aliasing samples of the Workbench: 5, 8 (the default), 11, 16 or 32; samples of Eevee and
Cycles). --size, --engine and --samples are for a .png, --frame too (a .abc, .obj or .blend holds every
frame imported): given with another output they are refused.

RUN_DIR is the folder an `mca run` wrote (its --out) or its automata.pvd; OUT's folder must exist and be
writable, and OUT must not be a folder (checked before the import).

A problem with the run folder, the arguments or the output is one line on stderr and exit code 1; any other
failure is one line too (what failed, on which run folder) and exits with 2 (MCA_CLI_TRACEBACK=1 adds
Python's traceback).
"""

import os
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

USAGE = ("usage: blender -b --factory-startup --python blender/mca_cli.py -- RUN_DIR OUT.abc|OUT.obj|OUT.png|OUT.blend "
         "[--frame N] [--frames N] [--size WxH] [--engine workbench|eevee|cycles] [--samples N]")


WORKBENCH_SAMPLES = ("5", "8", "11", "16", "32")  # its anti-aliasing's choices (scene.display.render_aa)


class UsageError(Exception):
    """A bad argument: one line on stderr; `usage` adds the usage line where the command's shape was wrong."""

    def __init__(self, message, usage=False):
        super().__init__(message)
        self.usage = usage


class OutputError(Exception):
    """An output that cannot be written: one line, without the usage."""


def parse(argv):
    if "--" not in argv:
        raise UsageError("no arguments after '--'", usage=True)
    args = argv[argv.index("--") + 1:]
    opts = {"frame": None, "frames": None, "size": None, "samples": 8, "engine": "workbench"}
    given = set()
    pos = []
    k = 0
    while k < len(args):
        a = args[k]
        if a in ("-h", "--help"):
            print(__doc__)
            sys.exit(0)
        if a.startswith("--"):
            key = a[2:]
            if key not in opts or k + 1 >= len(args):
                raise UsageError(f"unknown option or missing value: {a}", usage=True)
            value = args[k + 1]
            try:
                if key == "engine":
                    if value not in ("workbench", "eevee", "cycles"):
                        raise ValueError
                    opts[key] = value
                elif key == "size":
                    w, h = value.lower().split("x")
                    opts[key] = (int(w), int(h))
                    if not (16 <= opts[key][0] <= 16384 and 16 <= opts[key][1] <= 16384):
                        raise ValueError
                else:
                    opts[key] = int(value)
                    if opts[key] < (1 if key in ("frames", "samples") else 0):
                        raise ValueError
            except ValueError:
                raise UsageError(f"{a} {value}: expected " +
                                 ("WxH, 16 to 16384 each" if key == "size" else "workbench, eevee or cycles" if key == "engine"
                                  else f"a whole number >= {1 if key in ('frames', 'samples') else 0}"))
            given.add(key)
            k += 2
            continue
        pos.append(a)
        k += 1
    if len(pos) != 2:
        raise UsageError(f"expected RUN_DIR and OUT, got {len(pos)} arguments", usage=True)
    run_dir, out = pos
    if not run_dir:
        raise UsageError("RUN_DIR is empty: give the folder an `mca run` wrote (its --out)")
    if not out:
        raise UsageError("OUT is empty: give the file to write (OUT.abc, OUT.obj, OUT.png or OUT.blend)")
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".abc", ".obj", ".png", ".blend"):
        raise UsageError(f"{out}: the output's extension picks what to write: .abc, .obj, .png or .blend")
    # Options that would change nothing are refused rather than passed over.
    if "frame" in given and ext != ".png":
        raise UsageError(f"--frame picks the frame of a .png; {out} holds every frame imported (--frames N: the first N)")
    if ext != ".png" and given & {"size", "engine", "samples"}:
        raise UsageError(f"--{sorted(given & {'size', 'engine', 'samples'})[0]} is for a .png; {out} is not rendered")
    if opts["engine"] == "workbench" and str(opts["samples"]) not in WORKBENCH_SAMPLES:
        raise UsageError(f"--samples {opts['samples']}: the Workbench's anti-aliasing takes "
                         f"{', '.join(WORKBENCH_SAMPLES[:-1])} or {WORKBENCH_SAMPLES[-1]} samples")
    return run_dir, out, ext, opts


def check_output(out):
    """Refuses, before the import, an output Blender could not write: a folder of that name (Blender's save
    would rename it to NAME1 and write beside it), a folder that does not exist, one that cannot be written."""
    full = os.path.abspath(out)
    parent = os.path.dirname(full)
    if os.path.isdir(full):
        raise OutputError(f"{out} is a folder: give a file name to write (remove or rename the folder, or write "
                          f"{os.path.join(out, 'NAME' + os.path.splitext(out)[1])})")
    if not os.path.isdir(parent):
        raise OutputError(f"{out}: its folder {parent} does not exist; create it first (mkdir -p {parent})")
    try:
        fd, probe = tempfile.mkstemp(prefix=".mca_cli_", dir=parent)
        os.close(fd)
        os.remove(probe)
    except OSError as e:
        raise OutputError(f"{out}: cannot write in {parent} ({e.strerror or e}); choose a folder you can write to")


def written(path, what):
    """Refuses a file Blender's exporter or renderer did not write (it reports that only in its log)."""
    if not os.path.isfile(path):
        raise OutputError(f"{what} wrote no {path} (Blender's messages above say why): check that its folder can be "
                          "written and has room")


def check_frame(run_dir, opts):
    """Refuses --frame past the frames the run lists (those imported: --frames), before the import."""
    from io_import_mca import reader
    folder, _ = reader.run_folder(run_dir)
    pvd = os.path.join(folder, "automata.pvd")
    if not os.path.isfile(pvd):
        return  # (the import names what is wrong with the folder)
    frames = len(reader.read_pvd(pvd))
    if opts["frames"] is not None:
        frames = min(frames, opts["frames"])
    if frames and opts["frame"] >= frames:
        raise UsageError(f"--frame {opts['frame']}: the run has frames 0 to {frames - 1}" +
                         (f" (--frames {opts['frames']})" if opts["frames"] is not None and
                          opts["frames"] == frames else ""))


def render(scene, out, opts, frames):
    import bpy
    frame = opts["frame"] if opts["frame"] is not None else frames - 1
    if frame >= frames:
        raise UsageError(f"--frame {frame}: the run has frames 0 to {frames - 1}")
    engine = opts["engine"]
    if engine == "workbench":
        scene.render.engine = "BLENDER_WORKBENCH"
        shading = scene.display.shading
        shading.light = "STUDIO"
        shading.color_type = "VERTEX"  # the colour attribute: mca's fragment colours
        shading.show_cavity = False
        shading.show_shadows = False
        scene.display.render_aa = str(opts["samples"])  # (one of WORKBENCH_SAMPLES: checked with the options)
    elif engine == "eevee":  # the material "mca colour" reads the colour attribute
        scene.render.engine = "BLENDER_EEVEE"
        scene.eevee.taa_render_samples = opts["samples"]
    else:
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = opts["samples"]
        scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    if opts["size"]:
        scene.render.resolution_x, scene.render.resolution_y = opts["size"]
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 90
    scene.render.filepath = os.path.abspath(out)
    scene.frame_set(frame)
    bpy.ops.render.render(write_still=True)
    written(out, "Blender's render")
    return frame


STAGE = ["while reading the arguments for", None]  # what main() does, and on which run folder


def main():
    run_dir, out, ext, opts = parse(sys.argv)
    STAGE[1] = run_dir
    check_output(out)
    import bpy
    if ext == ".abc" and not bpy.app.alembic.supported:
        raise UsageError(f"{out}: this Blender ({bpy.app.version_string}) is built without Alembic "
                         "(bpy.app.alembic.supported is False; Debian's blender package is): run this script with a "
                         "Blender from blender.org, which has it, or write OUT.obj (an OBJ file per frame) or "
                         "OUT.blend instead")
    from io_import_mca import reader
    reader.check_dependencies()
    if ext == ".png" and opts["frame"] is not None:
        check_frame(run_dir, opts)
    from io_import_mca import build
    # An empty scene: the factory start-up's cube, light and camera go.
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    scene = bpy.context.scene
    t0 = time.perf_counter()
    STAGE[0] = "while importing"
    result = build.import_run(bpy.context, run_dir, max_frames=opts["frames"])
    for w in result.run.warnings:
        print(f"mca_cli: warning: {w}", file=sys.stderr)
    print(f"mca_cli: imported {result.frames} frame{'' if result.frames == 1 else 's'} from {result.run.dir} in {time.perf_counter() - t0:.2f} s")
    STAGE[0] = f"while writing {out} from"
    t0 = time.perf_counter()
    if ext == ".abc":
        bpy.ops.wm.alembic_export(filepath=os.path.abspath(out), start=scene.frame_start, end=scene.frame_end,
                                  evaluation_mode="RENDER", face_sets=False, uvs=False, export_custom_properties=True)
        written(out, "Blender's Alembic exporter")
        print(f"mca_cli: wrote {out} (frames {scene.frame_start} to {scene.frame_end}) in "
              f"{time.perf_counter() - t0:.2f} s")
    elif ext == ".obj":
        stem = os.path.splitext(os.path.abspath(out))[0]
        # The frames' objects (each shown at its frame only) and the balls; the ground stays out.
        if result.ground is not None:
            result.ground.hide_viewport = result.ground.hide_render = True
        bpy.ops.wm.obj_export(filepath=stem + ".obj", export_animation=True, start_frame=scene.frame_start,
                              end_frame=scene.frame_end, export_selected_objects=False, apply_modifiers=True,
                              export_eval_mode="DAG_EVAL_RENDER", export_colors=True, export_materials=False,
                              export_uv=False)
        files = [f"{stem}{k}.obj" for k in range(scene.frame_start, scene.frame_end + 1)]
        for w in files:
            written(w, "Blender's OBJ exporter")
        what = files[0] if len(files) == 1 else f"{files[0]} to {files[-1]}"
        print(f"mca_cli: wrote {what} in {time.perf_counter() - t0:.2f} s")
    elif ext == ".png":
        frame = render(scene, out, opts, result.frames)
        print(f"mca_cli: rendered frame {frame} (t = {result.run.times[frame]:.4g} s) with {opts['engine']} to {out} in "
              f"{time.perf_counter() - t0:.2f} s")
    else:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(out))
        written(out, "Blender's save")
        print(f"mca_cli: saved {out}")


if __name__ == "__main__":
    code = 0
    try:
        main()
    except UsageError as e:
        print(f"mca_cli: error: {e}" + (f"\n{USAGE}" if e.usage else ""), file=sys.stderr)
        code = 1
    except OutputError as e:
        print(f"mca_cli: error: {e}", file=sys.stderr)
        code = 1
    except Exception as e:  # noqa: BLE001 - every failure ends with one line and a non-zero exit code
        from_reader = type(e).__name__ == "RunError"
        if from_reader:
            print(f"mca_cli: error: {e}", file=sys.stderr)
        else:
            if os.environ.get("MCA_CLI_TRACEBACK"):
                traceback.print_exc()
            first = (str(e).strip().splitlines() or [""])[0]
            print(f"mca_cli: internal error {STAGE[0]} {STAGE[1] or ''}: {type(e).__name__}: {first} (a bug of "
                  "mca_cli.py or a damaged run folder: run mca again into an empty folder, and report it with "
                  "MCA_CLI_TRACEBACK=1's output if it persists)", file=sys.stderr)
        code = 1 if from_reader else 2
    sys.stdout.flush()
    sys.stderr.flush()
    # Blender goes on after a --python script (and exits 0); leave with the script's code.
    os._exit(code)
