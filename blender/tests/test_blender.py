#!/usr/bin/env python3
"""The Blender tests (ctest -R blender): real Blender, headless, on runs made by the built mca.

    test_blender.py --mca MCA --blender BLENDER --work DIR CASE

Cases setup_* make the run folders under DIR (ctest fixtures), the others import, export and render them.
"""

import argparse
import os
import re
import shutil
import struct
import subprocess
import sys
import time
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON_ROOT = os.path.dirname(HERE)  # blender/
CLI = os.path.join(ADDON_ROOT, "mca_cli.py")
# The default wall on the paper's cubic lattice (the default scene until the random lattice became the
# default): the runs these tests were written on. The default scene itself: the case setup_random.
CUBIC_WALL = os.path.join(os.path.dirname(ADDON_ROOT), "scenes", "wall_ball_cubic.toml")
IN_BLENDER = os.path.join(HERE, "in_blender.py")


def run(cmd, env=None, timeout=600):
    print("$", " ".join(cmd), flush=True)
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, timeout=timeout)
    sys.stdout.write(p.stdout[-6000:])
    sys.stdout.write(p.stderr[-6000:])
    return p


def blender_cmd(a, script, *args):
    return [a.blender, "-b", "--factory-startup", "--python", script, "--", *args]


def in_blender(a, *args, env=None):
    p = run(blender_cmd(a, IN_BLENDER, *args), env=env)
    if p.returncode != 0 or "PASSED" not in p.stdout:
        sys.exit(f"checks in Blender failed (exit {p.returncode})")


def mca_run(a, out, *args):
    p = run([a.mca, "run", *args, "--out", out, "--quiet"])
    if p.returncode != 0:
        sys.exit(f"mca run failed ({p.returncode})")


# A sphere of 0.3 m radius as an OBJ (a subdivided octahedron pushed onto the sphere).
def write_sphere_obj(path, radius=0.3, level=3):
    verts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(level):
        mid = {}

        def middle(i, j):
            key = (min(i, j), max(i, j))
            if key not in mid:
                p = [(verts[i][k] + verts[j][k]) / 2 for k in range(3)]
                n = sum(c * c for c in p) ** 0.5
                verts.append(tuple(c / n for c in p))
                mid[key] = len(verts) - 1
            return mid[key]
        new = []
        for i, j, k in faces:
            ij, jk, ki = middle(i, j), middle(j, k), middle(k, i)
            new += [(i, ij, ki), (ij, j, jk), (ki, jk, k), (ij, jk, ki)]
        faces = new
    with open(path, "w") as f:
        for v in verts:
            f.write("v {:.9g} {:.9g} {:.9g}\n".format(*(radius * c for c in v)))
        for t in faces:
            f.write("f {} {} {}\n".format(*(i + 1 for i in t)))


SURFACE_SCENE = """name = "blender_sphere"
[solver]
spacing = 0.05
gravity = [0.0, 0.0, -9.81]
seed = 3
[output]
duration = 0.012
frame_rate = 500.0
surface = true
fragments = true
fragment_min_automata = 2
[ground]
enabled = true
height = 0.0
[[object]]
name = "sphere"
shape = "mesh"
mesh = "sphere.obj"
position = [0.0, 0.0, 0.35]
material = "concrete"
[[object]]
name = "block"
size = [0.2, 0.2, 0.2]
position = [0.6, 0.0, 0.1]
material = "glass"
[[projectile]]
name = "ball"
radius = 0.1
material = "steel"
position = [0.0, -0.42, 0.35]
velocity = [0.0, 40.0, 0.0]
"""


def setup_surface(a):
    folder = os.path.join(a.work, "surface_scene")
    os.makedirs(folder, exist_ok=True)
    write_sphere_obj(os.path.join(folder, "sphere.obj"))
    with open(os.path.join(folder, "scene.toml"), "w") as f:
        f.write(SURFACE_SCENE)
    mca_run(a, os.path.join(a.work, "surface"), os.path.join(folder, "scene.toml"))


def copy_run(src, dst):
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst)


def patch_point_value(vtu, array, index, value, vtk_type="Int32", form="<i"):
    """Sets element `index` of the point array `array` (of `vtk_type`, one value of `form` an element) of an mca
    frame (appended raw data, UInt64 block headers) to `value`."""
    with open(vtu, "rb") as f:
        data = bytearray(f.read())
    marker = data.find(b"<AppendedData")
    start = data.find(b"_", marker) + 1
    m = re.search(rb'<DataArray type="' + vtk_type.encode() + rb'" Name="' + array.encode() + rb'"[^>]*offset="(\d+)"',
                  data[:marker])
    assert m, (vtu, array)
    size = struct.calcsize(form)
    at = start + int(m.group(1)) + 8 + size * index
    data[at:at + size] = struct.pack(form, value)
    with open(vtu, "wb") as f:
        f.write(data)


def replace_in(path, old, new):
    with open(path, "rb") as f:
        data = f.read()
    assert old in data, (path, old)
    with open(path, "wb") as f:
        f.write(data.replace(old, new, 1))


def make_bad_inputs(a):
    """Broken run folders, each made from the short run."""
    short = os.path.join(a.work, "short")
    bad = os.path.join(a.work, "bad")
    shutil.rmtree(bad, ignore_errors=True)
    os.makedirs(bad)
    d = os.path.join(bad, "no_frames")
    os.makedirs(d)
    shutil.copy(os.path.join(short, "scene.toml"), d)  # a run with output.vtk = false writes no frames
    d = os.path.join(bad, "empty_pvd")
    copy_run(short, d)
    with open(os.path.join(d, "automata.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                "  <Collection>\n  </Collection>\n</VTKFile>\n")
    d = os.path.join(bad, "missing_frame")
    copy_run(short, d)
    os.remove(os.path.join(d, "frames", "automata_000002.vtu"))
    d = os.path.join(bad, "cut_short")
    copy_run(short, d)
    vtu = os.path.join(d, "frames", "automata_000003.vtu")
    size = os.path.getsize(vtu)
    with open(vtu, "r+b") as f:
        f.truncate(size // 2)
    for name, file, old, new in (("newer_vtu", "frames/automata_000000.vtu",
                                  b'<VTKFile type="UnstructuredGrid" version="1.0"',
                                  b'<VTKFile type="UnstructuredGrid" version="2.0"'),
                                 ("newer_pvd", "automata.pvd", b'<VTKFile type="Collection" version="0.1"',
                                  b'<VTKFile type="Collection" version="0.2"')):
        d = os.path.join(bad, name)
        copy_run(short, d)
        path = os.path.join(d, file)
        with open(path, "rb") as f:
            data = f.read()
        assert old in data, (path, old)
        with open(path, "wb") as f:
            f.write(data.replace(old, new, 1))
    d = os.path.join(bad, "not_a_run")
    os.makedirs(d)
    with open(os.path.join(d, "notes.txt"), "w") as f:
        f.write("not a run\n")
    d = os.path.join(bad, "bad_summary")
    copy_run(short, d)
    with open(os.path.join(d, "summary.json"), "r+") as f:
        f.truncate(40)
    d = os.path.join(bad, "mixed_frames")  # a frame of another run, with other automata
    copy_run(short, d)
    shutil.copy(os.path.join(a.work, "surface", "frames", "automata_000001.vtu"),
                os.path.join(d, "frames", "automata_000001.vtu"))
    d = os.path.join(bad, "no_summary")
    copy_run(short, d)
    os.remove(os.path.join(d, "summary.json"))
    # Files of the right name but the wrong shape: valid JSON or TOML holding the wrong types or values.
    d = os.path.join(bad, "summary_list")
    copy_run(short, d)
    with open(os.path.join(d, "summary.json"), "w") as f:
        f.write("[1, 2]\n")
    for name, old, new in (("gravity_string", "gravity = [0.0, 0.0, -9.81]", 'gravity = "down"'),
                           ("ground_number", "[ground]", "ground_was = 1\n[ground_x]"),
                           ("fov_string", "fov = 40.0", 'fov = "wide"'),
                           ("fov_zero", "fov = 40.0", "fov = 0.0")):
        d = os.path.join(bad, name)
        copy_run(short, d)
        path = os.path.join(d, "scene.toml")
        with open(path) as f:
            text = f.read()
        assert old in text, (path, old)
        text = text.replace(old, new, 1)
        if name == "ground_number":
            text = "ground = 5\n" + text
        with open(path, "w") as f:
            f.write(text)
    d = os.path.join(bad, "render_zero")  # render options that would divide by zero: warned, the defaults used
    copy_run(short, d)
    os.makedirs(os.path.join(d, "render"), exist_ok=True)
    with open(os.path.join(d, "render", "render.json"), "w") as f:
        f.write('{"fps": 0, "width": -5, "height": 0}\n')
    d = os.path.join(bad, "frames_file")  # frames/ a file
    copy_run(short, d)
    shutil.rmtree(os.path.join(d, "frames"))
    with open(os.path.join(d, "frames"), "w") as f:
        f.write("x\n")
    d = os.path.join(bad, "frame_folder")  # a frame a folder
    copy_run(short, d)
    os.remove(os.path.join(d, "frames", "automata_000001.vtu"))
    os.makedirs(os.path.join(d, "frames", "automata_000001.vtu"))
    # Ids that size arrays, damaged: a fragment id of 2^31 - 1 made the importer allocate 16 GB (killed for
    # its memory), a negative one failed in numpy.
    for name, array, value in (("fragment_huge", "fragment", 2**31 - 1), ("object_negative", "object", -1)):
        d = os.path.join(bad, name)
        copy_run(short, d)
        patch_point_value(os.path.join(d, "frames", "automata_000002.vtu"), array, 5, value)
    d = os.path.join(bad, "no_projectiles")  # the balls' collection left behind: imports without balls, warned
    copy_run(short, d)
    os.remove(os.path.join(d, "projectiles.pvd"))
    # Files that are not files of a run (the hostile review of 2026-12-06): a FIFO hung Blender for good,
    # /dev/zero filled its memory, and a collection's frame could lie anywhere (/etc/passwd was opened).
    d = os.path.join(bad, "frame_fifo")
    copy_run(short, d)
    os.remove(os.path.join(d, "frames", "automata_000001.vtu"))
    os.mkfifo(os.path.join(d, "frames", "automata_000001.vtu"))
    d = os.path.join(bad, "frame_dev_zero")
    copy_run(short, d)
    os.remove(os.path.join(d, "frames", "automata_000001.vtu"))
    os.symlink("/dev/zero", os.path.join(d, "frames", "automata_000001.vtu"))
    d = os.path.join(bad, "projectiles_fifo")  # (the collections are read as the frames are: it hung too)
    copy_run(short, d)
    os.remove(os.path.join(d, "projectiles.pvd"))
    os.mkfifo(os.path.join(d, "projectiles.pvd"))
    for name, file in (("pvd_absolute", b"/etc/passwd"), ("pvd_dot_dot", b"../short/frames/automata_000001.vtu")):
        d = os.path.join(bad, name)
        copy_run(short, d)
        replace_in(os.path.join(d, "automata.pvd"), b'file="frames/automata_000001.vtu"', b'file="' + file + b'"')
    # Values mca never writes: a NaN position, a fragment id stored as a float, an array's offset missing.
    d = os.path.join(bad, "nan_points")
    copy_run(short, d)
    patch_point_value(os.path.join(d, "frames", "automata_000002.vtu"), "Points", 3 * 7 + 1, float("nan"), "Float32", "<f")
    d = os.path.join(bad, "fragment_float")
    copy_run(short, d)
    replace_in(os.path.join(d, "frames", "automata_000002.vtu"), b'type="Int32" Name="fragment"',
               b'type="Float32" Name="fragment"')
    d = os.path.join(bad, "no_offset")
    copy_run(short, d)
    vtu = os.path.join(d, "frames", "automata_000002.vtu")
    with open(vtu, "rb") as f:
        data = f.read()
    m = re.search(rb'(<DataArray type="Int32" Name="fragment"[^>]*) offset="\d+"', data)
    with open(vtu, "wb") as f:
        f.write(data[:m.start()] + m.group(1) + data[m.end():])
    # A frame of 20 GB of zeros (a sparse file): refused at its first MB, not read whole into memory.
    d = os.path.join(bad, "frame_sparse")
    copy_run(short, d)
    os.truncate(os.path.join(d, "frames", "automata_000001.vtu"), 0)
    os.truncate(os.path.join(d, "frames", "automata_000001.vtu"), 20 << 30)
    # A run still going writes automata.pvd before projectiles.pvd: imported to the frames both list, warned.
    d = os.path.join(bad, "projectiles_behind")
    copy_run(short, d)
    os.remove(os.path.join(d, "summary.json"))
    pvd = os.path.join(d, "projectiles.pvd")
    with open(pvd) as f:
        lines = f.read().splitlines(keepends=True)
    last = max(k for k, l in enumerate(lines) if "<DataSet" in l)
    with open(pvd, "w") as f:
        f.writelines(lines[:last] + lines[last + 1:])
    return bad


def cli_refuses(a, name, args, words, code=1, env=None):
    """mca_cli.py refuses: one line on stderr naming the problem (`words`), exit code `code`, no traceback."""
    r = run(blender_cmd(a, CLI, *args), env=env)
    lines = [l for l in r.stderr.splitlines() if l.startswith("mca_cli:")]
    ok = r.returncode == code and words in r.stderr and len(lines) == 1 and \
        lines[0].startswith("mca_cli: error:" if code == 1 else "mca_cli: internal error") and "Traceback" not in r.stderr
    print(("ok: " if ok else "FAIL: ") + f"mca_cli.py, {name}: exit {r.returncode}, says '{words}'")
    if not ok:
        sys.exit(f"mca_cli.py on {name}: exit {r.returncode}, stderr: {r.stderr[-500:]}")
    return r


def bad_cli(a):
    """The command line's arguments and outputs: each refusal one line on stderr, exit code 1, nothing
    written or renamed."""
    short = os.path.join(a.work, "short")
    out = os.path.join(a.work, "bad_cli")
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "x.png"))
    os.makedirs(os.path.join(out, "d.blend"))
    missing = os.path.join(out, "no_such_folder")
    for name, args, words in (
            ("--frames 0", [short, os.path.join(out, "y.png"), "--frames", "0"], "expected a whole number >= 1"),
            ("--samples 0", [short, os.path.join(out, "y.png"), "--samples", "0"], "expected a whole number >= 1"),
            ("--samples 7 with the Workbench", [short, os.path.join(out, "y.png"), "--samples", "7"],
             "the Workbench's anti-aliasing takes 5, 8, 11, 16 or 32 samples"),
            ("--frame with a .obj", [short, os.path.join(out, "y.obj"), "--frame", "3"], "--frame picks the frame of a .png"),
            ("--size with a .blend", [short, os.path.join(out, "y.blend"), "--size", "64x64"], "--size is for a .png"),
            ("an empty RUN_DIR", ["", os.path.join(out, "y.png")], "RUN_DIR is empty"),
            ("a run folder that does not exist", [os.path.join(out, "no_run"), os.path.join(out, "y.blend")],
             os.path.join(out, "no_run") + " does not exist"),
            ("a .png that is a folder", [short, os.path.join(out, "x.png")], "x.png is a folder"),
            ("a .blend that is a folder", [short, os.path.join(out, "d.blend")], "d.blend is a folder"),
            ("an output in a missing folder", [short, os.path.join(missing, "x.png")],
             f"its folder {missing} does not exist; create it first"),
            ("a .png in /proc", [short, "/proc/x.png"], "cannot write in /proc"),
            ("a .blend in /proc", [short, "/proc/x.blend"], "cannot write in /proc"),
            ("an .obj in /proc", [short, "/proc/x.obj"], "cannot write in /proc")):
        cli_refuses(a, name, args, words)
    if not os.path.isdir(os.path.join(out, "d.blend")) or os.path.exists(os.path.join(out, "d.blend1")) or \
            os.path.exists(missing):
        sys.exit(f"mca_cli.py changed {out}: {sorted(os.listdir(out))}")
    # The run's automata.pvd names its run, as in the add-on.
    blend = os.path.join(out, "by_pvd.blend")
    r = run(blender_cmd(a, CLI, os.path.join(short, "automata.pvd"), blend, "--frames", "2"))
    if r.returncode != 0 or not os.path.isfile(blend):
        sys.exit(f"mca_cli.py on the run's automata.pvd: exit {r.returncode}, stderr: {r.stderr[-500:]}")
    # A failure nobody foresaw (the reader made to fail): one line naming what failed and the run folder.
    wrapper = os.path.join(out, "failing_cli.py")
    with open(wrapper, "w") as f:
        f.write("import runpy, sys\n"
                f"sys.path.insert(0, {ADDON_ROOT!r})\n"
                "from io_import_mca import reader\n"
                "def fail(*args, **kwargs):\n"
                "    raise ZeroDivisionError('float division by zero')\n"
                "reader.Run = fail\n"
                f"runpy.run_path({CLI!r}, run_name='__main__')\n")
    p = run([a.blender, "-b", "--factory-startup", "--python", wrapper, "--", short, os.path.join(out, "z.blend")])
    lines = [l for l in p.stderr.splitlines() if l.startswith("mca_cli:")]
    if p.returncode != 2 or len(lines) != 1 or "internal error while importing " + short not in lines[0] or \
            "ZeroDivisionError" not in lines[0] or "Traceback" in p.stderr:
        sys.exit(f"mca_cli.py on an unforeseen failure: exit {p.returncode}, stderr: {p.stderr[-500:]}")
    print("ok: an unforeseen failure is one line naming the run folder, exit 2")


def png_pixels(path):
    """(width, height, rows of RGB bytes) of an 8-bit RGB or RGBA, non-interlaced PNG (what Blender writes)."""
    import zlib
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, colour, _, _, interlace = header
    assert depth == 8 and colour in (2, 6) and interlace == 0, header
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        ft = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            left = line[i - bpp] if i >= bpp else 0
            up = prev[i]
            ul = prev[i - bpp] if i >= bpp else 0
            if ft == 1:
                line[i] = (line[i] + left) & 255
            elif ft == 2:
                line[i] = (line[i] + up) & 255
            elif ft == 3:
                line[i] = (line[i] + (left + up) // 2) & 255
            elif ft == 4:
                p = left + up - ul
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - ul)
                line[i] = (line[i] + (left if pa <= pb and pa <= pc else up if pb <= pc else ul)) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, bpp, rows


def check_render(path, width, height):
    """The picture shows the run: the wall's light grey (the main body), the red ball, pieces in colours, and
    the darker checkered ground and background around them."""
    w, h, bpp, rows = png_pixels(path)
    assert (w, h) == (width, height), f"{path} is {w}x{h}, expected {width}x{height}"
    counts = {"wall": 0, "ball": 0, "pieces": 0, "ground and background": 0}
    for row in rows:
        for x in range(w):
            r, g, b = row[x * bpp:x * bpp + 3]
            spread = max(r, g, b) - min(r, g, b)
            if r > 120 and g < 60 and b < 60:
                counts["ball"] += 1
            elif spread > 50:
                counts["pieces"] += 1
            elif r > 110 and spread < 30:
                counts["wall"] += 1
            elif r < 105 and spread < 30:
                counts["ground and background"] += 1
    total = w * h
    print("pixels:", {k: f"{100 * v / total:.2f} %" for k, v in counts.items()})
    if not (counts["wall"] > 0.05 * total and counts["ball"] > 0.002 * total and counts["pieces"] > 0.001 * total
            and counts["ground and background"] > 0.2 * total):
        sys.exit(f"{path} does not show the run (pixels: {counts})")


def load_reader():
    """The add-on's reader module alone (its package imports bpy)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("mca_reader", os.path.join(ADDON_ROOT, "io_import_mca", "reader.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def check_colours(a):
    """The add-on's fragment colours equal the renderer's, automaton by automaton, in every frame of the
    cubic wall (885 fragments at the end), and for many single-automaton pieces."""
    import numpy as np
    reader = load_reader()
    run_dir = os.path.join(a.work, "default")
    frames = [(f["object"], f["fragment"]) for f in reader.Run(run_dir).frames]
    n = 20000  # every automaton its own piece but one main body: the hue of 19,999 indices
    frames.append((np.zeros(n, np.int32), np.concatenate([np.zeros(n // 2 + 1, np.int32),
                                                          np.arange(1, n - n // 2, dtype=np.int32)])))
    for k, (obj, frag) in enumerate(frames):
        text = f"{int(obj.max()) + 1} {len(obj)}\n" + "\n".join(f"{o} {f}" for o, f in zip(obj, frag)) + "\n"
        p = subprocess.run([a.colours], input=text, stdout=subprocess.PIPE, text=True, check=True)
        want = np.array(p.stdout.split(), np.int64).reshape(-1, 3)
        got = reader.fragment_colours(frag, obj).astype(np.int64)
        differ = int(np.any(want != got, axis=1).sum())
        pieces = len(np.unique(frag))
        print(f"frame {k}: {len(obj)} automata, {pieces} fragments, {differ} colours differ")
        if differ:
            sys.exit(f"frame {k}: {differ} automata coloured unlike the renderer")


def check_rotations(a):
    """The rotations reconstructed for frames without orientation (older runs) against the orientations the
    frames carry, on the cubic wall: the automata of fragments turn with them (Kabsch), pieces by their
    spin."""
    import numpy as np
    reader = load_reader()
    # A block of 4 x 3 x 2 automata turned as one body by known rotations of every axis and size: the
    # reconstruction gives them back (and a lone automaton turns by its spin).
    rng = np.random.default_rng(7)
    grid = np.array([[x, y, z] for x in range(4) for y in range(3) for z in range(2)], float) * 0.05
    p0 = np.vstack([grid, [[1.0, 1.0, 1.0]]])
    frag = np.array([0] * len(grid) + [1])
    zero = np.zeros((len(p0), 3), np.float32)
    for trial in range(200):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(0, np.pi)
        q = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
        w, x, y, z = q
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                      [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                      [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        spin = np.zeros((len(p0), 3), np.float32)
        spin[-1] = axis * angle / 0.002  # the lone automaton turns by the same angle over the frame
        frames = [dict(points=p0.astype(np.float32), fragment=frag, angular_velocity=zero),
                  dict(points=(p0 @ R.T + [0.3, -0.2, 0.1]).astype(np.float32), fragment=frag, angular_velocity=spin)]
        got = reader.automaton_rotations(p0, frames, [0.0, 0.002])[1].astype(float)
        # the lone automaton: the mean of the spins at the frame's two ends (0 and `spin`) turns it by half
        off = np.degrees(2 * np.arccos(np.abs(got[:-1] @ q).clip(0, 1))).max()
        half = np.concatenate([[np.cos(angle / 4)], np.sin(angle / 4) * axis])
        off_lone = np.degrees(2 * np.arccos(min(1.0, abs(float(got[-1] @ half)))))
        if off > 0.1 or off_lone > 0.1:  # float32 quaternions resolve about 0.05 degrees near identity
            sys.exit(f"rotation {angle:.3f} rad about {axis}: the block comes back {off:.4f} degrees off, the lone "
                     f"automaton {off_lone:.4f}")
    print("ok: 200 known rotations of a block come back within 0.1 degrees, and a lone automaton's spin")
    run = reader.Run(os.path.join(a.work, "default"))
    if not run.has_orientation:
        sys.exit("the cubic wall's frames carry no orientation")
    truth = run.rotations()
    guess = reader.automaton_rotations(run.initial_positions(), run.frames, run.times)
    exposed = run.exposed()
    for k in (len(run.frames) // 2, len(run.frames) - 1):
        def off(q):  # degrees between q and the frame's orientation, exposed automata
            dot = np.abs((truth[k].astype(float) * q.astype(float)).sum(axis=1)).clip(0, 1)
            return np.degrees(2 * np.arccos(dot))[exposed[k]]
        angle = off(guess[k])
        unturned = off(np.tile([1.0, 0, 0, 0], (len(guess[k]), 1)))
        median, p90 = np.median(angle), np.percentile(angle, 90)
        print(f"frame {k}: the exposed automata's reconstructed rotation is off by {median:.1f} degrees (median), "
              f"{p90:.1f} (90th percentile); unturned cubes would be off by {np.median(unturned):.1f} and "
              f"{np.percentile(unturned, 90):.1f}")
        if not (median < 10 and p90 < 40 and p90 < 0.5 * np.percentile(unturned, 90)):
            sys.exit(f"frame {k}: the reconstructed rotations are far from the frames' orientations")


def check_surface_gap(a):
    """A resumed run whose frame 1 was lost leaves it out of every collection (mca resume): the importer takes
    each frame's bound surface by the frame's number, not by its place in the collection."""
    reader = load_reader()
    d = os.path.join(a.work, "surface_gap")
    copy_run(os.path.join(a.work, "surface"), d)
    for pvd in ("automata.pvd", "projectiles.pvd", "surface.pvd"):
        path = os.path.join(d, pvd)
        if not os.path.exists(path):
            continue
        with open(path) as f:
            lines = f.readlines()
        kept = [line for line in lines if "_000001." not in line]
        assert len(kept) == len(lines) - 1, (path, "frame 1 not listed once")
        with open(path, "w") as f:
            f.writelines(kept)
    os.remove(os.path.join(d, "frames", "automata_000001.vtu"))
    run = reader.Run(d)
    got = [os.path.basename(p) for p in run.surface_files]
    want = [f"surface_{k:06d}.ply" for k in [0] + list(range(2, len(got) + 1))]
    print("surface files of the frames:", got)
    if got != want:
        sys.exit(f"the frames' surfaces are {got}, not {want}: paired by place, not by frame")
    # A fragment mesh of the finished run missing is said (it was left out without a word), and none is said
    # where every one is there.
    whole = reader.Run(os.path.join(a.work, "surface"))
    if any("fragment meshes" in w for w in whole.warnings) or len(whole.fragment_files) < 2:
        sys.exit(f"the surface run: {len(whole.fragment_files)} fragment meshes, warnings {whole.warnings}")
    lost = sorted(whole.fragment_files)[1]
    os.remove(os.path.join(d, "fragments", f"fragment_{lost:03d}.ply"))
    said = [w for w in reader.Run(d).warnings if "fragment meshes" in w]
    print("with a fragment mesh removed:", said)
    if len(said) != 1 or f"lacks 1 of the {len(whole.fragment_files)} fragment meshes" not in said[0] or \
            f"fragment_{lost:03d}.ply" not in said[0]:
        sys.exit(f"a missing fragment mesh: {said}")


def check_unknown_lattice(a):
    """A run folder without scene.toml: the lattice is not known, and every automaton is drawn (the cubic
    rule, taken as the default, hid a third of a random-lattice wall's faces: a see-through picture; a
    hostile review, 2026-12-06), with a warning that says so; with its scene.toml the cubic wall draws fewer."""
    import numpy as np
    reader = load_reader()
    for name, lattice in (("random", "random"), ("short", "cubic")):
        d = os.path.join(a.work, f"{name}_without_scene")
        shutil.rmtree(d, ignore_errors=True)
        copy_run(os.path.join(a.work, name), d)
        os.remove(os.path.join(d, "scene.toml"))
        run = reader.Run(d)
        drawn = [int(e.sum()) for e in run.exposed()]
        automata = len(run.frames[0]["damage"])
        print(f"{name} ({lattice}) without scene.toml: {drawn} of {automata} automata drawn; {run.warnings}")
        if drawn != [automata] * len(drawn):
            sys.exit(f"{name} without scene.toml drew {drawn} of {automata} automata, not every one")
        if not any("every automaton is drawn (the lattice is not known)" in w for w in run.warnings):
            sys.exit(f"no warning says every automaton is drawn: {run.warnings}")
        whole = reader.Run(os.path.join(a.work, name))
        known = [int(e.sum()) for e in whole.exposed()]
        if (lattice == "cubic") != (known[0] < automata):
            sys.exit(f"{name} with its scene.toml ({lattice}) drew {known[0]} of {automata} at frame 0")
        if lattice == "cubic":
            # The box's faces exactly, as the renderer draws it (fewer than six links): its automata less those
            # inside (sites at whole spacings, which a grid of cells of the spacing took for one cell lower or
            # not by their rounding: 4,124 drawn, a hostile review, 2026-12-07).
            p0 = whole.initial_positions()
            n = np.rint((p0.max(axis=0) - p0.min(axis=0)) / whole.spacing).astype(int) + 1
            surface = int(np.prod(n) - np.prod(n - 2))
            print(f"{name}: a box of {n.tolist()} automata, {surface} on its faces; {known[0]} drawn at frame 0")
            if int(np.prod(n)) != automata or known[0] != surface:
                sys.exit(f"{name} drew {known[0]} automata at frame 0, not the {surface} on its faces")
        shutil.rmtree(d, ignore_errors=True)


def check_many_frames(a):
    """Frames that together take more than a quarter of the machine's memory are refused after the first is
    read, with how many fit and the setting that imports fewer (30,000 frames grew to 6.8 GB and ended in a
    MemoryError called a bug); as many as fit are imported. The machine is made small for the test."""
    reader = load_reader()
    short = os.path.join(a.work, "short")
    frames = reader.Run(short).frame_count
    first = reader.Run(short, max_frames=1).frames[0]
    each, automata = sum(v.nbytes for v in first.values()), len(first["points"])
    reader._memory_bytes = lambda: 4 * each * (frames - 1)  # a quarter holds all but one frame
    try:
        reader.Run(short)
    except reader.RunError as e:
        print(f"refused: {e}")
        want = f"{frames:,} frames of {automata:,} automata would take about"
        if want not in str(e) or f"at most about {frames - 1:,}" not in str(e) or "--frames N" not in str(e):
            sys.exit(f"'{e}' does not say '{want}', how many fit and how to import fewer")
    else:
        sys.exit(f"{frames} frames read where {frames - 1} fit")
    if len(reader.Run(short, max_frames=frames - 1).frames) != frames - 1:
        sys.exit("the frames that fit were not imported")


def check_large_files(a):
    """Files far larger than mca writes (sparse files of 20 GB, which a hostile folder or a damaged disk gives)
    are refused or read only as far as their headers declare, never read whole: the importer held the whole
    file in memory before. A frame or a mesh with 20 GB after its data reads as the file without them."""
    import numpy as np
    import resource
    reader = load_reader()
    big = 20 << 30
    d = os.path.join(a.work, "large")
    shutil.rmtree(d, ignore_errors=True)
    try:
        copy_run(os.path.join(a.work, "surface"), d)
        want = reader.Run(os.path.join(a.work, "surface"))
        rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        # Data after what the headers declare: read as the files without it.
        for name in ("frames/automata_000002.vtu", "surface/surface_000001.ply"):
            os.truncate(os.path.join(d, name), big)
        got = reader.Run(d)
        for key in ("points", "fragment", "object", "radius", "damage"):
            if not np.array_equal(got.frames[2][key], want.frames[2][key]):
                sys.exit(f"frame 2's {key} differs once 20 GB follow its data")
        ply = [reader.read_ply(os.path.join(r, "surface", "surface_000001.ply")) for r in (d, want.dir)]
        if not all(np.array_equal(x, y) for x, y in zip(ply[0][:2], ply[1][:2])):
            sys.exit("the surface's PLY differs once 20 GB follow its data")
        # The OBJ reader on the same surface, written as OBJ (groups fragment_N), then with 20 GB of zeros after
        # it: one line of 20 GB, refused at its first 4 KB.
        v, f, values = ply[1]
        obj = os.path.join(d, "surface", "surface_000001.obj")
        with open(obj, "w") as out:
            out.write("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in v.tolist()))
            group = None
            for tri, g in zip(f.tolist(), (values if values is not None else np.zeros(len(f), int)).tolist()):
                if g != group:
                    out.write(f"g fragment_{g}\n")
                    group = g
                out.write(f"f {tri[0] + 1} {tri[1] + 1} {tri[2] + 1}\n")
        with open(obj, "rb") as fh:
            lines = fh.read().count(b"\n")
        ov, of, _ = reader.read_obj(obj)
        if not (np.array_equal(ov, v) and np.array_equal(of, f)):
            sys.exit("the OBJ of the surface reads otherwise than its PLY")
        os.truncate(obj, big)

        def refused(call, words):
            try:
                call()
            except reader.RunError as e:
                print(f"refused: {e}")
                if words not in str(e):
                    sys.exit(f"'{e}' does not say '{words}'")
                return
            sys.exit(f"read without an error, though '{words}'")

        refused(lambda: reader.read_obj(obj), f"surface_000001.obj:{lines + 1}: a line longer than 4096 characters, "
                                              "which mca never writes")
        # Whole files of zeros, and text files past what mca writes.
        for name in ("frames/automata_000003.vtu", "summary.json", "automata.pvd"):
            path = os.path.join(d, name)
            os.truncate(path, 0)
            os.truncate(path, big)
        refused(lambda: reader.read_vtu(os.path.join(d, "frames", "automata_000003.vtu")),
                "automata_000003.vtu is cut short or not a VTK file written by mca (no appended data in its first MB)")
        refused(lambda: reader.read_pvd(os.path.join(d, "automata.pvd")),
                "automata.pvd is 21,474,836,480 bytes, more than mca writes there (1,073,741,824 at most)")
        scene = os.path.join(d, "scene.toml")
        with open(scene, "rb") as fh:
            text = fh.read()
        os.truncate(scene, 65 << 20)
        refused(lambda: reader.Run(d), "scene.toml is 68,157,440 bytes, more than mca writes there (67,108,864 at most)")
        with open(scene, "wb") as fh:
            fh.write(text)
        refused(lambda: reader.Run(d), "summary.json is 21,474,836,480 bytes, more than mca writes there")
        # A header that declares 4e9 points with a matching array (48 GB, sparse): refused by its count
        # against the run's and against the machine's memory, before the array is read (a frame of 5e8 was
        # read whole, 6 GB, before Blender ran out of memory).
        n = 4 * 10 ** 9
        lying = os.path.join(d, "frames", "automata_000004.vtu")
        head = ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
                f'header_type="UInt64">\n<UnstructuredGrid>\n<Piece NumberOfPoints="{n}" NumberOfCells="0">\n'
                '<Points>\n<DataArray type="Float32" NumberOfComponents="3" format="appended" offset="0"/>\n'
                '</Points>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding="raw">\n_').encode()
        with open(lying, "wb") as fh:
            fh.write(head + (12 * n).to_bytes(8, "little"))
        os.truncate(lying, len(head) + 8 + 12 * n)
        refused(lambda: reader.read_vtu(lying, expect=(4800, "frame 0")),
                f"automata_000004.vtu holds {n} automata, frame 0 4800: frames of different runs are mixed")
        refused(lambda: reader.read_vtu(lying), f"automata_000004.vtu declares {n} points, about 256 GB of arrays, "
                                                "more than a quarter of this machine's")
        grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
        print(f"peak memory grew by {grown:.0f} MB")
        if grown > 200:
            sys.exit(f"reading the large files grew the peak memory by {grown:.0f} MB")
    finally:
        shutil.rmtree(d, ignore_errors=True)  # (20 GB files, sparse: a copy of the folder would not be)


def check_far_fragments(a):
    """A fragment far from the origin is written in double (float32 folded it, or left it empty): the add-on's
    reader takes the double PLY, closed and whole, and mca_cli.py imports the run with it into a .blend."""
    import numpy as np
    reader = load_reader()
    run_dir = os.path.join(a.work, "far")
    scene = os.path.join(a.work, "far.toml")
    with open(scene, "w") as f:
        f.write('name = "far"\n[solver]\nspacing = 0.05\nlattice = "cubic"\ngravity = [0, 0, 0]\n'
                '[output]\nfragments = true\nduration = 0.0001\n'
                '[[object]]\nname = "box"\nshape = "box"\nsize = [2.0, 0.4, 1.5]\nposition = [1e5, 5e4, 2e4]\n')
    mca_run(a, run_dir, scene, "--steps", "2")
    v, f, _ = reader.read_ply(os.path.join(run_dir, "fragments", "fragment_000.ply"))
    if v.dtype != np.float64:
        sys.exit(f"the far fragment was read as {v.dtype}, not the double it is written in")
    edges = {}
    for tri in f.tolist():
        for k in range(3):
            e = (tri[k], tri[(k + 1) % 3])
            edges[e] = edges.get(e, 0) + 1
    if any(n != 1 for n in edges.values()) or any((b, a_) not in edges for a_, b in edges):
        sys.exit("the far fragment's mesh is not closed (an edge not used once each way)")
    c = v - v.mean(axis=0)
    volume = float(np.einsum("ij,ij->i", c[f[:, 0]], np.cross(c[f[:, 1]], c[f[:, 2]])).sum()) / 6
    if abs(volume / 1.2 - 1) > 0.003:
        sys.exit(f"the far fragment holds {volume:.4f} m^3 of the box's 1.2")
    print(f"ok: the fragment 1e5 m out: {len(f)} triangles in double, closed, {volume:.4f} m^3")
    blend = os.path.join(a.work, "far.blend")
    if os.path.exists(blend):
        os.remove(blend)
    r = run(blender_cmd(a, CLI, run_dir, blend))
    if r.returncode != 0 or not os.path.isfile(blend) or "Traceback" in r.stderr:
        sys.exit(f"mca_cli.py did not import the run with the far fragment into {blend} (exit {r.returncode})")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--mca", required=True)
    p.add_argument("--blender", required=True)
    p.add_argument("--work", required=True)
    p.add_argument("--colours", help="the mca_render_colours program (the colours case)")
    p.add_argument("case")
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)
    short = os.path.join(a.work, "short")
    case = a.case
    if case == "setup_short":  # the cubic wall's first 10 ms: 6 frames, the ball strikes at 7 ms
        mca_run(a, short, CUBIC_WALL, "--duration", "0.01")
    elif case == "setup_default":  # the whole cubic wall (60 ms, 31 frames)
        mca_run(a, os.path.join(a.work, "default"), CUBIC_WALL)
    elif case == "setup_random":  # the default scene (the random lattice) to 20 ms: 5 frames
        mca_run(a, os.path.join(a.work, "random"), "--duration", "0.02")
    elif case == "import_random":
        in_blender(a, "import", os.path.join(a.work, "random"))
    elif case == "setup_surface":
        setup_surface(a)
    elif case == "import_short":
        in_blender(a, "import", short)
    elif case == "import_default":
        in_blender(a, "import", os.path.join(a.work, "default"), "10")
    elif case == "surface":
        in_blender(a, "surface", os.path.join(a.work, "surface"))
    elif case == "alembic":
        abc = os.path.join(a.work, "short.abc")
        if os.path.exists(abc):
            os.remove(abc)
        probe = run([a.blender, "-b", "--factory-startup", "--python-expr",
                     "import bpy; print('alembic supported:', bpy.app.alembic.supported)"])
        supported = "alembic supported: True" in probe.stdout
        r = run(blender_cmd(a, CLI, short, abc))
        if supported:
            if r.returncode != 0 or not os.path.isfile(abc) or os.path.getsize(abc) < 10000:
                sys.exit(f"mca_cli.py did not write {abc} (exit {r.returncode})")
            in_blender(a, "alembic", short, abc)
        else:
            # Debian's Blender has no Alembic: the script says so, names the way out, and writes nothing.
            if r.returncode != 1 or "built without Alembic" not in r.stderr or "OUT.obj" not in r.stderr or \
                    "Traceback" in r.stderr or os.path.exists(abc):
                sys.exit(f"mca_cli.py on a Blender without Alembic: exit {r.returncode}, stderr {r.stderr[-400:]}")
            print("ok: this Blender has no Alembic; mca_cli.py refuses .abc with exit 1 and says why")
    elif case == "obj_sequence":
        folder = os.path.join(a.work, "obj_sequence")
        shutil.rmtree(folder, ignore_errors=True)
        os.makedirs(folder)  # mca_cli.py refuses to write into a folder that does not exist
        r = run(blender_cmd(a, CLI, short, os.path.join(folder, "short.obj")))
        frames = sum(1 for n in os.listdir(os.path.join(short, "frames")) if n.startswith("automata_"))
        files = sorted(os.listdir(folder)) if os.path.isdir(folder) else []
        want = [f"short{k}.obj" for k in range(frames)]
        if r.returncode != 0 or sorted(want) != files:
            sys.exit(f"mca_cli.py wrote {files}, expected {want} (exit {r.returncode})")
        in_blender(a, "obj_sequence", short, folder)
    elif case == "render":
        png = os.path.join(a.work, "short.png")
        if os.path.exists(png):
            os.remove(png)
        r = run(blender_cmd(a, CLI, short, png, "--size", "480x270", "--frame", "5"))
        if r.returncode != 0 or not os.path.isfile(png):
            sys.exit(f"mca_cli.py did not render {png} (exit {r.returncode})")
        check_render(png, 480, 270)
    elif case == "blend":
        blend = os.path.join(a.work, "short3.blend")
        if os.path.exists(blend):
            os.remove(blend)
        r = run(blender_cmd(a, CLI, short, blend, "--frames", "3"))
        if r.returncode != 0 or not os.path.isfile(blend):
            sys.exit(f"mca_cli.py did not write {blend} (exit {r.returncode})")
        in_blender(a, "blend", short, blend)
    elif case == "bad_input":
        bad = make_bad_inputs(a)
        in_blender(a, "bad_input", bad)
        # The command line: one line on stderr, exit code 1, no traceback.
        for name, args, words in (
                ("a folder that is no run", [os.path.join(bad, "not_a_run"), os.path.join(a.work, "x.blend")],
                 "not an mca run folder"),
                ("a run from a newer mca", [os.path.join(bad, "newer_vtu"), os.path.join(a.work, "x.png")],
                 "newer mca"),
                ("a half-written run", [os.path.join(bad, "cut_short"), os.path.join(a.work, "x.blend")],
                 "cut short"),
                ("no frames", [os.path.join(bad, "no_frames"), os.path.join(a.work, "x.blend")], "holds no frames"),
                ("an output of unknown type", [short, os.path.join(a.work, "x.fbx")], "extension"),
                ("a frame past the last", [short, os.path.join(a.work, "x.png"), "--frame", "99"], "frames 0 to 5"),
                ("no arguments", [], "expected RUN_DIR and OUT"),
                ("a summary that is no JSON object", [os.path.join(bad, "summary_list"), os.path.join(a.work, "x.blend")],
                 "summary.json is not the summary mca writes"),
                ("frames/ a file", [os.path.join(bad, "frames_file"), os.path.join(a.work, "x.blend")],
                 "a folder on its path is a file")):
            r = cli_refuses(a, name, args, words)
            if "--frame" in args and "mca_cli: imported" in r.stdout:
                sys.exit("mca_cli.py imported the run before it refused --frame 99")
    elif case == "bad_cli":
        bad_cli(a)
    elif case == "far_fragments":
        check_far_fragments(a)
    elif case == "missing_numpy":
        in_blender(a, "missing_numpy", short)
    elif case == "install":
        scripts = os.path.join(a.work, "user_scripts")
        shutil.rmtree(scripts, ignore_errors=True)
        os.makedirs(scripts)
        # the README's command
        zip_path = os.path.join(a.work, "io_import_mca.zip")
        if os.path.exists(zip_path):
            os.remove(zip_path)
        r = run([sys.executable, "-m", "zipfile", "-c", zip_path, os.path.join(ADDON_ROOT, "io_import_mca")])
        with zipfile.ZipFile(zip_path) as z:
            names = z.namelist()
        if r.returncode != 0 or "io_import_mca/__init__.py" not in names:
            sys.exit(f"python3 -m zipfile made {names} (exit {r.returncode})")
        env = dict(os.environ, BLENDER_USER_SCRIPTS=scripts,
                   BLENDER_USER_CONFIG=os.path.join(a.work, "user_config"))
        # in_blender.py puts blender/ on the path; the installed copy must be the one found first
        in_blender(a, "install", zip_path, short, env=env)
    elif case == "colours":
        check_colours(a)
    elif case == "rotations":
        check_rotations(a)
    elif case == "surface_gap":
        check_surface_gap(a)
    elif case == "many_frames":
        check_many_frames(a)
    elif case == "unknown_lattice":
        check_unknown_lattice(a)
    elif case == "large_files":
        check_large_files(a)
    else:
        sys.exit(f"unknown case {case}")


if __name__ == "__main__":
    t0 = time.time()
    main()
    print(f"done in {time.time() - t0:.1f} s")
