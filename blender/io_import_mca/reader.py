"""Reading an mca run folder with the standard library and numpy only (no bpy).

What a run folder holds is described in the README ("Outputs"): automata.pvd with frames/automata_NNNNNN.vtu
(VTK XML, raw appended binary), projectiles.pvd, surface/surface_NNNNNN.ply or .obj with
`[output] surface = true`, fragments/fragment_NNN.ply with `[output] fragments = true`, scene.toml,
summary.json and render/render.json after `mca run --render`.

Every problem with the folder is raised as RunError with a message for the user (the file, what is wrong
and what to do); the add-on shows it in Blender's report area and the command line on stderr.
"""

import json
import math
import os
import re
import stat
import xml.etree.ElementTree as ET

try:
    import numpy as np
except ImportError:  # reported by check_dependencies(), before anything is read
    np = None

try:
    import tomllib
except ImportError:  # Python before 3.11
    tomllib = None

# The VTK XML versions mca writes: the .vtu frames and the .pvd collections. A newer version is a file
# written by a newer mca, whose layout this reader does not know.
VTU_VERSION = (1, 0)
PVD_VERSION = (0, 1)
PLY_FORMAT = "binary_little_endian 1.0"


class RunError(Exception):
    """A run folder that cannot be imported; the message says which file and why."""


def check_dependencies():
    """The modules the reader needs, with the package that gives each (Debian's names)."""
    missing = []
    if np is None:
        missing.append("numpy (Debian: apt-get install python3-numpy)")
    if tomllib is None:
        missing.append("tomllib (Python 3.11 or newer: Blender 3.4 from Debian runs Python 3.11)")
    if missing:
        raise RunError("the mca importer needs " + " and ".join(missing) + "; install it and restart Blender")


def _unreadable(path, e):
    """The RunError for a file of the run that cannot be opened (other than a missing one): a folder where a
    file should be, a file where a folder should be, no permission."""
    if isinstance(e, IsADirectoryError):
        return RunError(f"{path} is a folder, not the file mca writes there: remove or rename it and run mca again")
    if isinstance(e, NotADirectoryError):
        return RunError(f"{path} cannot be read: a folder on its path is a file (the run folder is damaged): run mca "
                        "again into an empty folder")
    return RunError(f"{path} cannot be read ({e.strerror or e}): check its permissions")


_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


# The most that is read of a file of the run before its layout is known: the XML head of a frame (mca's:
# about 2 KB) or a mesh's PLY header; and the largest text files mca writes. A file past these is not one
# of the run's (a sparse file of 20 GB, a device): it is refused, not read whole into Blender's memory.
_HEAD_MAX = 1 << 20
SCENE_MAX = 64 << 20  # mca reads scene files of up to 64 MB (src/io/scene_io.cpp)
TEXT_MAX = 1 << 30    # summary.json (about 20 KB and 0.5 KB a ball), a collection (about 90 bytes a frame)
LINE_MAX = 4096       # a line of an OBJ mca writes (v x y z, f a b c, g fragment_N: under 100 characters)


class _RegularFile:
    """A file of the run opened for reading, with its size: only a regular file (through a link too) is
    opened; a FIFO would wait for ever, and /dev/zero fill the memory. `missing`: the message when it does
    not exist. A context manager that closes the file."""

    def __init__(self, path, missing):
        try:
            st = os.stat(path)  # (before opening: a device is not even opened)
        except FileNotFoundError:
            raise RunError(missing)
        except OSError as e:
            raise _unreadable(path, e)
        _check_regular(path, st)
        # O_NONBLOCK (POSIX): a FIFO put at the name after the check above opens without waiting for a writer;
        # O_BINARY (Windows): no line-end translation.
        nonblock = getattr(os, "O_NONBLOCK", 0)
        try:
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_BINARY", 0) | nonblock)
        except FileNotFoundError:
            raise RunError(missing)
        except OSError as e:
            raise _unreadable(path, e)
        try:
            st = os.fstat(fd)
            _check_regular(path, st)
            if nonblock:
                os.set_blocking(fd, True)
        except BaseException:
            os.close(fd)
            raise
        self.file = os.fdopen(fd, "rb")
        self.size = st.st_size
        self.path = path

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.file.close()

    def read_at(self, offset, count):
        """`count` bytes from `offset`; a file that holds fewer (cut short since its size was taken) is
        damaged."""
        try:
            self.file.seek(offset)
            data = self.file.read(count)
        except OSError as e:
            raise _unreadable(self.path, e)
        if len(data) != count:
            raise RunError(f"{self.path} is cut short (it ends before byte {offset + count:,}): run mca again")
        return data

    def read_head(self):
        """Up to _HEAD_MAX bytes from the start."""
        return self.read_at(0, min(self.size, _HEAD_MAX))


def _check_regular(path, st):
    if stat.S_ISREG(st.st_mode):
        return
    if stat.S_ISDIR(st.st_mode):
        raise _unreadable(path, IsADirectoryError())
    kind = next((k for test, k in _KINDS if test(st.st_mode)), "not a regular file")
    raise RunError(f"{path} is {kind}, not a file of the run (mca writes regular files): copy the run's whole "
                   "folder again, or run mca again")


def _read_bytes(path, missing, limit=TEXT_MAX):
    """The bytes of a text file of the run (a regular file, of at most `limit` bytes); `missing`: the message
    when it does not exist."""
    with _RegularFile(path, missing) as f:
        if f.size > limit:
            raise RunError(f"{path} is {f.size:,} bytes, more than mca writes there ({limit:,} at most): it is "
                           "not a file of the run; copy the run's whole folder again, or run mca again")
        return f.read_at(0, f.size)


def _damaged(path, e):
    """The RunError for a file of the run whose header or layout does not parse (a field cut, a count that is
    not a number): the file named, with what went wrong."""
    return RunError(f"{path} is cut short or damaged ({type(e).__name__}: {e}); it is not as mca writes it: run "
                    "mca again")


def _check_finite(path, name, arr, what="automaton"):
    """mca writes finite values only: a NaN or infinity is a damaged file (named, with the array and the
    element)."""
    if arr.dtype.kind == "f":
        bad = ~np.isfinite(arr)
        if bad.any():
            k = int(np.flatnonzero(bad.reshape(len(arr), -1).any(axis=1))[0]) if arr.ndim > 1 else \
                int(np.flatnonzero(bad)[0])
            raise RunError(f"{path}: array '{name}' holds {arr[k]} at {what} {k}: mca writes finite values only; the "
                           "file is damaged: run mca again")


def _version(text, path):
    try:
        return tuple(int(p) for p in text.split("."))
    except (AttributeError, ValueError):
        raise RunError(f"{path}: version '{text}' is not a version number; is this a file written by mca?")


def _check_version(text, supported, kind, path):
    """Refuses a `kind` file ("VTK collection", "VTK file") of a version newer than `supported`."""
    if _version(text, path) > supported:
        raise RunError(f"{path} has {kind} version {text}, newer than the {'.'.join(map(str, supported))} this "
                       "add-on reads: it was written by a newer mca; install the add-on of that mca "
                       "(blender/io_import_mca in its repository)")


# ---------------------------------------------------------------------------------------------------------
# VTK XML

def frame_number(rel, index):
    """The number of a frame's file as mca names it (frames/automata_000012.vtu: 12), else its index."""
    m = re.search(r"_(\d+)\.vtu$", rel)
    return int(m.group(1)) if m else index


def read_pvd(path):
    """The (time, file) entries of a .pvd collection, the file relative to the collection's folder."""
    try:
        root = ET.fromstring(_read_bytes(path, f"{path} is missing"))  # (a regular file only: not a FIFO)
    except ET.ParseError as e:
        raise RunError(f"{path} is not a complete VTK collection ({e}); it may be cut short: run mca again")
    if root.tag != "VTKFile" or root.get("type") != "Collection":
        raise RunError(f"{path} is not a VTK collection (a VTKFile of type Collection)")
    _check_version(root.get("version", ""), PVD_VERSION, "VTK collection", path)
    entries = []
    for ds in root.iter("DataSet"):
        try:
            entries.append((float(ds.get("timestep")), ds.get("file")))
        except (TypeError, ValueError):
            raise RunError(f"{path}: a DataSet has no timestep or file")
        t = entries[-1][0]
        if not math.isfinite(t) or (len(entries) > 1 and t < entries[-2][0]):
            raise RunError(f"{path}: a DataSet's timestep {ds.get('timestep')} is not a time after the one before "
                           "(mca lists its frames in time order): the collection is damaged or was edited; run mca "
                           "again")
        # A frame is a file of the run's folder: not a path that leaves it (/etc/passwd, ../elsewhere).
        rel = entries[-1][1]
        if not rel or os.path.isabs(rel) or ".." in re.split(r"[/\\]", rel):
            raise RunError(f"{path}: a DataSet's file '{rel}' lies outside the run folder (mca lists its frames as "
                           "frames/NAME.vtu): the collection is damaged or was edited; run mca again")
    return entries


_VTK_TYPES = {"Float32": "<f4", "Float64": "<f8", "Int8": "<i1", "UInt8": "<u1", "Int16": "<i2",
              "UInt16": "<u2", "Int32": "<i4", "UInt32": "<u4", "Int64": "<i8", "UInt64": "<u8"}
_ATTR = re.compile(r'(\w+)="([^"]*)"')


def read_vtu(path, names=None, listed_by="automata.pvd", expect=None):
    """Points and point fields of a .vtu written by mca (appended raw binary, UInt64 block headers).

    Returns (points (N, 3) float32, {field name: array (N,) or (N, components)}). `names`: the fields to
    read (all when None); `listed_by`: the collection that names the file (for the message when it is
    missing); `expect`: None, or (N, what says so) for a frame whose count the run gives (its summary, its
    first frame), checked before any array is read."""
    with _RegularFile(path, f"{path} is missing (the run's {listed_by} lists it): the run folder is incomplete; "
                            "run mca again or copy the whole folder") as f:
        return _read_vtu(f, names, expect)


def _memory_bytes():
    """The machine's memory in bytes (0 where the system does not say)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 0


def _read_vtu(f, names, expect=None):
    """read_vtu from the open file `f` (a _RegularFile): its XML head, then the arrays asked for."""
    path = f.path
    head = f.read_head()
    marker = head.find(b"<AppendedData")
    start = head.find(b"_", marker) + 1 if marker >= 0 else 0
    if marker < 0 or start == 0:
        raise RunError(f"{path} is cut short or not a VTK file written by mca (no appended data"
                       f"{' in its first MB' if len(head) == _HEAD_MAX else ''}): run mca again")
    header = head[:marker].decode("utf-8", "replace")
    m = re.search(r"<VTKFile([^>]*)>", header)
    if not m:
        raise RunError(f"{path} is not a VTK XML file")
    top = dict(_ATTR.findall(m.group(1)))
    if top.get("type") != "UnstructuredGrid":
        raise RunError(f"{path} is a VTK file of type {top.get('type')}, not the UnstructuredGrid mca writes")
    _check_version(top.get("version", ""), VTU_VERSION, "VTK file", path)
    if top.get("byte_order") != "LittleEndian" or top.get("header_type") != "UInt64" or "compressor" in top:
        raise RunError(f"{path}: byte order {top.get('byte_order')}, header type {top.get('header_type')}"
                       f"{', compressed' if 'compressor' in top else ''}: not the layout mca writes "
                       "(little-endian, UInt64 headers, uncompressed); write the frames with mca")
    piece = re.search(r"<Piece([^>]*)>", header)
    try:
        n = int(dict(_ATTR.findall(piece.group(1)))["NumberOfPoints"])
    except (AttributeError, KeyError, ValueError):
        raise RunError(f"{path} has no NumberOfPoints")
    if n < 0:
        raise RunError(f"{path}: NumberOfPoints {n} is negative: the file is damaged; run mca again")
    if expect is not None and n != expect[0]:
        raise RunError(f"{path} holds {n} automata, {expect[1]} {expect[0]}: frames of different runs are mixed in "
                       "the folder, or the frame is damaged; run mca again into an empty folder")
    # A header's count, read as it says, must fit: a frame declaring 5e8 points (6 GB of a sparse file of
    # zeros) was read whole before Blender ran out of memory. The importer holds every frame; one frame of
    # more than a quarter of the machine's memory is not a run it can import here.
    memory = _memory_bytes()
    if memory and n * 64 > memory / 4:
        raise RunError(f"{path} declares {n} points, about {n * 64 / 1e9:.3g} GB of arrays, more than a quarter of this "
                       f"machine's {memory / 1e9:.3g} GB: the frame is damaged, or the run too large to import here")
    try:
        points, fields = _vtu_arrays(f, header, start, n, names)
    except (KeyError, ValueError, IndexError, OverflowError, TypeError) as e:
        raise _damaged(path, e)
    if points is None:
        raise RunError(f"{path} has no points")
    _check_finite(path, "Points", points, "point")
    for name, arr in fields.items():
        _check_finite(path, name, arr)
    return points, fields


def _vtu_arrays(f, header, start, n, names):
    """(points, fields) of read_vtu from the header's DataArrays and the appended data of the open file `f`
    (a _RegularFile): each array is read from its offset, and only the arrays asked for."""
    path = f.path
    points = None
    fields = {}
    section = None
    for tag in re.finditer(r"<(/?)(PointData|Points|Cells|DataArray)([^>]*)>", header):
        closing, name, attrs = tag.groups()
        if name != "DataArray":
            section = None if closing else name
            continue
        a = dict(_ATTR.findall(attrs))
        if section not in ("PointData", "Points"):
            continue
        if section == "PointData" and names is not None and a.get("Name") not in names:
            continue
        if a.get("format") != "appended" or a.get("type") not in _VTK_TYPES:
            raise RunError(f"{path}: array '{a.get('Name')}' is {a.get('format')} {a.get('type')}, not an appended "
                           "array of a known type")
        comps = int(a.get("NumberOfComponents", "1"))
        if int(a["offset"]) < 0 or comps < 1:
            raise ValueError(f"array '{a.get('Name')}': offset {a['offset']}, {comps} components")
        offset = start + int(a["offset"])
        if offset + 8 > f.size:
            raise RunError(f"{path} is cut short (array '{a.get('Name')}' lies past its end): run mca again")
        nbytes = int.from_bytes(f.read_at(offset, 8), "little")
        dtype = np.dtype(_VTK_TYPES[a["type"]])
        if nbytes != n * comps * dtype.itemsize or offset + 8 + nbytes > f.size:
            raise RunError(f"{path} is cut short or damaged (array '{a.get('Name')}' holds {nbytes} bytes for "
                           f"{n} points of {comps} x {dtype.itemsize}): run mca again")
        arr = np.frombuffer(f.read_at(offset + 8, nbytes), dtype, n * comps)
        arr = arr.reshape(n, comps) if comps > 1 else arr
        if section == "Points":
            points = arr
        else:
            fields[a["Name"]] = arr
    return points, fields


# ---------------------------------------------------------------------------------------------------------
# Meshes

def read_ply(path):
    """(vertices (V, 3) float32, or float64 for a fragment mca wrote in double, triangles (F, 3) int32, per-face
    values or None) of a PLY written by mca."""
    with _RegularFile(path, f"{path} is missing") as f:
        return _read_ply(f)


def _read_ply(f):
    """read_ply from the open file `f` (a _RegularFile): its header, then exactly the data it declares."""
    path = f.path
    head = f.read_head()
    end = head.find(b"end_header\n")
    if not head.startswith(b"ply\n") or end < 0:
        raise RunError(f"{path} is not a PLY file (or its header is cut short)")
    lines = head[:end].decode("ascii", "replace").splitlines()
    body = end + len(b"end_header\n")
    fmt_line = next((l for l in lines if l.startswith("format ")), "")
    if fmt_line != "format " + PLY_FORMAT:
        raise RunError(f"{path}: '{fmt_line}', not the '{PLY_FORMAT}' mca writes")
    nv = nf = None
    value = False
    element = None
    props = {"vertex": [], "face": []}
    for l in lines:
        w = l.split()
        if w[:1] == ["element"]:
            if len(w) != 3 or not w[2].isdigit():
                raise RunError(f"{path}: header line '{l}' is not 'element NAME COUNT' as mca writes it; the file "
                               "is damaged: run mca again")
            element = w[1]
            if element == "vertex":
                nv = int(w[2])
            elif element == "face":
                nf = int(w[2])
        elif w[:1] == ["property"] and element in props:
            props[element].append(" ".join(w[1:]))
    # (float32 vertices, or double for a fragment far from the origin, which float32 would fold)
    vtype = {"float": "<f4", "double": "<f8"}.get(props["vertex"][0].split()[0] if props["vertex"] else "")
    if vtype is None or props["vertex"] != [f"{props['vertex'][0].split()[0]} {a}" for a in "xyz"] or \
            not props["face"] or props["face"][0] != "list uchar int vertex_indices" or len(props["face"]) > 2 or \
            (len(props["face"]) == 2 and not props["face"][1].startswith("int ")):
        raise RunError(f"{path}: vertex or face properties are not the ones mca writes "
                       "(float or double x y z; uchar-int vertex_indices and an optional int)")
    vsize = 3 * np.dtype(vtype).itemsize
    value = len(props["face"]) == 2
    if nv is None or nf is None:
        raise RunError(f"{path}: the header has no vertex or face count")
    fdt = np.dtype([("n", "u1"), ("v", "<i4", (3,))] + ([("value", "<i4")] if value else []))
    need = body + vsize * nv + fdt.itemsize * nf
    if f.size < need:
        raise RunError(f"{path} is cut short ({f.size} bytes, its header declares {need}): run mca again")
    data = f.read_at(body, need - body)
    verts = np.frombuffer(data, vtype, 3 * nv, 0).reshape(nv, 3)
    faces = np.frombuffer(data, fdt, nf, vsize * nv)
    if nf and (np.any(faces["n"] != 3) or faces["v"].min() < 0 or faces["v"].max() >= nv):
        raise RunError(f"{path}: faces that are not triangles of its vertices (mca writes triangles)")
    _check_finite(path, "vertex", verts, "vertex")
    return verts, np.ascontiguousarray(faces["v"]), (np.ascontiguousarray(faces["value"]) if value else None)


def read_obj(path):
    """The same as read_ply for a surface written as OBJ (groups `fragment_N`)."""
    with _RegularFile(path, f"{path} is missing") as f:
        return _read_obj(f)


def _obj_lines(f):
    """The lines of the open OBJ `f` (a _RegularFile), numbered from 1, read a line at a time: a line longer
    than mca writes is a damaged file (a sparse file of 20 GB is one such line)."""
    try:
        for k, raw in enumerate(iter(lambda: f.file.readline(LINE_MAX + 1), b""), 1):
            if len(raw) > LINE_MAX:
                raise RunError(f"{f.path}:{k}: a line longer than {LINE_MAX} characters, which mca never writes; the "
                               "file is damaged: run mca again")
            yield k, raw.decode("ascii", "replace").rstrip("\r\n")
    except OSError as e:
        raise _unreadable(f.path, e)


def _read_obj(f):
    """read_obj from the open file `f` (a _RegularFile)."""
    path = f.path
    verts, faces, values = [], [], []
    group = -1
    for k, line in _obj_lines(f):
        if line.startswith(("v ", "f ")):
            # Three fields a line, as mca writes: one line of two would shift every vertex or face after it.
            if len(line[2:].split()) != 3:
                raise RunError(f"{path}:{k}: '{line.strip()}' is not a line of three fields (v x y z, f a b c) as "
                               "mca writes it; the file is damaged: run mca again")
            if line[0] == "v":
                verts.append(line[2:])
            else:
                faces.append(line[2:])
                values.append(group)
        elif line.startswith("g "):
            name = line[2:].strip()
            try:
                group = int(name.rsplit("_", 1)[1])
            except (IndexError, ValueError):
                raise RunError(f"{path}:{k}: group '{name}' is not the fragment_N mca writes")
            if not 0 <= group < 2 ** 31:
                raise RunError(f"{path}:{k}: group '{name}' is not a fragment number mca writes (0 to 2^31 - 1)")
    try:
        v = np.array(" ".join(verts).split(), dtype=np.float32).reshape(-1, 3)
        tri = np.array(" ".join(faces).split(), dtype=np.int64).reshape(-1, 3) - 1
    except ValueError:
        raise RunError(f"{path}: vertices or faces that are not the triangles mca writes (v x y z, f a b c)")
    if len(tri) and (tri.min() < 0 or tri.max() >= len(v)):
        raise RunError(f"{path}: a face refers to a vertex it does not have; the file is cut short or damaged")
    _check_finite(path, "vertex", v, "vertex")
    return v, tri.astype(np.int32), np.array(values, dtype=np.int32)


# ---------------------------------------------------------------------------------------------------------
# Colours: the renderer's `fragment` colouring (src/render/snapshot.cpp, fragment_colours)

def _byte(v):
    """rgb() of the renderer: a share 0..1 to a byte, rounded half away from zero."""
    return np.floor(255.0 * np.clip(np.asarray(v, np.float32), 0.0, 1.0) + 0.5).astype(np.uint8)


MAIN_BODY = _byte([0.72, 0.71, 0.68]) if np is not None else None


def piece_colours(first):
    """The colour (uint8 RGB) of a piece whose smallest automaton index is `first` (murmur3's finaliser of
    the index picks the hue, saturation and value), as the renderer's piece_colour."""
    with np.errstate(over="ignore"):
        x = np.asarray(first, np.uint32) + np.uint32(0x9E3779B9)
        x ^= x >> np.uint32(16)
        x *= np.uint32(0x85EBCA6B)
        x ^= x >> np.uint32(13)
        x *= np.uint32(0xC2B2AE35)
        x ^= x >> np.uint32(16)
    f32 = np.float32
    h = (x & np.uint32(0xFFFF)).astype(f32) / f32(65536.0) * f32(6.0)
    s = f32(0.55) + f32(0.25) * ((x >> np.uint32(16)) & np.uint32(0xFF)).astype(f32) / f32(255.0)
    v = f32(0.80) + f32(0.15) * (x >> np.uint32(24)).astype(f32) / f32(255.0)
    k = h.astype(np.int32)
    fr = h - k.astype(f32)
    p, q, u = v * (f32(1) - s), v * (f32(1) - s * fr), v * (f32(1) - s * (f32(1) - fr))
    table = [(v, u, p), (q, v, p), (p, v, u), (p, q, v), (u, p, v), (v, p, q)]
    out = np.empty((len(k), 3), np.float32)
    sector = k % 6
    for i, (r, g, b) in enumerate(table):
        sel = sector == i
        out[sel, 0], out[sel, 1], out[sel, 2] = r[sel], g[sel], b[sel]
    return _byte(out)


def fragment_colours(fragment, obj):
    """Per automaton, uint8 RGB: a fragment with more than half of its object's automata (the main body) is
    concrete grey, every other piece the hue of its smallest automaton index."""
    fragment = np.asarray(fragment, np.int64)
    obj = np.asarray(obj, np.int64)
    n = len(fragment)
    if n == 0:
        return np.zeros((0, 3), np.uint8)
    count = int(fragment.max()) + 1
    first = np.full(count, n, np.int64)
    np.minimum.at(first, fragment, np.arange(n))
    size = np.bincount(fragment, minlength=count)
    object_size = np.bincount(obj, minlength=int(obj.max()) + 1)
    used = first < n
    first_safe = np.where(used, first, 0)
    whole = object_size[obj[first_safe]]
    main = used & (2 * size > whole)
    colour = piece_colours(first_safe.astype(np.uint32))
    colour[main] = MAIN_BODY
    return colour[fragment]


def srgb_to_linear(c):
    """uint8 sRGB to linear floats (Blender's colour attributes are linear; mca's colours are sRGB bytes)."""
    c = np.asarray(c, np.float32) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


# ---------------------------------------------------------------------------------------------------------
# Geometry

def up_axis(scene):
    """The up direction: opposite gravity; z with gravity off (docs/scene-format.md, Coordinates)."""
    g = np.array(scene.get("solver", {}).get("gravity", [0.0, 0.0, -9.81]), float)
    g = g / max(np.abs(g).max(), 1e-300)  # (scaled first: a gravity of 1e308 has a norm past float)
    n = np.linalg.norm(g)
    return -g / n if n > 0 else np.array([0.0, 0.0, 1.0])


def exposed_at_start(p0, obj, spacing):
    """Automata with fewer than six lattice neighbours of their object at frame 0: on the object's surface
    (the renderer draws an automaton when fewer than six of its links are intact; inside a lattice every
    automaton has six). Neighbours are found on a grid of cells of the spacing."""
    n = len(p0)
    if n == 0:
        return np.zeros(0, bool)
    reach = 1.2 * spacing
    # Cells of the reach: two automata within it are in neighbouring cells. (Cells of the spacing put lattice
    # sites, at whole multiples of it, one cell low or not by their rounding: neighbours two cells apart were
    # not looked at, and 1,452 interior automata of the cubic wall counted as its surface's.)
    cell = np.floor((p0 - p0.min(axis=0)) / reach).astype(np.int64)
    dims = cell.max(axis=0) + 3
    key = ((cell[:, 0] + 1) * dims[1] + (cell[:, 1] + 1)) * dims[2] + (cell[:, 2] + 1)
    order = np.argsort(key, kind="stable")
    skey = key[order]
    count = np.zeros(n, np.int32)
    reach2 = reach ** 2
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                nk = key + (dx * dims[1] + dy) * dims[2] + dz
                lo = np.searchsorted(skey, nk, "left")
                hi = np.searchsorted(skey, nk, "right")
                # a cell holds one to eight sites of a lattice of this spacing: walk them
                most = int((hi - lo).max()) if n else 0
                for k in range(most):
                    has = lo + k < hi
                    a = np.nonzero(has)[0]
                    b = order[lo[has] + k]
                    d2 = ((p0[a] - p0[b]) ** 2).sum(axis=1)
                    near = (b != a) & (d2 < reach2) & (obj[a] == obj[b])
                    np.add.at(count, a[near], 1)
    return count < 6


def quat_multiply(a, b):
    aw, ax, ay, az = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bw, bx, by, bz = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=1)


def matrix_to_quat(R):
    """Quaternions (w, x, y, z) of rotation matrices (K, 3, 3)."""
    K = len(R)
    q = np.empty((K, 4))
    tr = R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2]
    # the largest of w, x, y, z decides which formula is well conditioned
    cand = np.stack([tr, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1)
    big = np.argmax(cand, axis=1)
    for case in range(4):
        sel = big == case
        if not sel.any():
            continue
        m = R[sel]
        if case == 0:
            s = 2.0 * np.sqrt(np.maximum(1.0 + tr[sel], 1e-300))
            q[sel] = np.stack([0.25 * s, (m[:, 2, 1] - m[:, 1, 2]) / s, (m[:, 0, 2] - m[:, 2, 0]) / s,
                               (m[:, 1, 0] - m[:, 0, 1]) / s], axis=1)
        else:
            i = case - 1
            j, k = (i + 1) % 3, (i + 2) % 3
            s = 2.0 * np.sqrt(np.maximum(1.0 + m[:, i, i] - m[:, j, j] - m[:, k, k], 1e-300))
            v = np.empty((len(m), 4))
            v[:, 0] = (m[:, k, j] - m[:, j, k]) / s
            v[:, 1 + i] = 0.25 * s
            v[:, 1 + j] = (m[:, j, i] + m[:, i, j]) / s
            v[:, 1 + k] = (m[:, k, i] + m[:, i, k]) / s
            q[sel] = v
    return q / np.linalg.norm(q, axis=1)[:, None]


def _turn(q, omega_a, omega_b, dt):
    """q turned by the mean of two angular velocities (world frame) over dt."""
    w = 0.5 * (omega_a.astype(float) + omega_b.astype(float))
    rate = np.linalg.norm(w, axis=1)
    half = 0.5 * rate * dt
    axis = np.divide(w, rate[:, None], out=np.zeros_like(w), where=rate[:, None] > 0)
    turn = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis], axis=1)
    out = quat_multiply(turn, q)
    return out / np.linalg.norm(out, axis=1)[:, None]


def automaton_rotations(p0, frames, times):
    """Orientation quaternions (w, x, y, z) of each automaton at each frame, for frames that hold no
    orientation (written by an mca before they did), found from what they hold: an automaton starts unturned (as in mca); one in a fragment of three
    or more automata not in a line turns with its fragment, whose rotation is the one that best carries the
    fragment's automata from their frame-0 places to their places now (Kabsch: the SVD of their covariance);
    one in a smaller piece turns from its orientation at the frame before by the mean of the angular
    velocities at the frame's two ends over the frame's time.

    `p0`: frame-0 positions (N, 3); `frames`: dicts with points, fragment, angular_velocity."""
    n = len(p0)
    q = np.zeros((n, 4))
    q[:, 0] = 1.0
    out = []
    for k, f in enumerate(frames):
        frag = np.asarray(f["fragment"], np.int64)
        p = f["points"].astype(float)
        count = np.bincount(frag, minlength=int(frag.max()) + 1 if n else 0).astype(float)
        safe = np.maximum(count, 1.0)
        c0 = np.stack([np.bincount(frag, p0[:, i], len(count)) for i in range(3)], axis=1) / safe[:, None]
        c = np.stack([np.bincount(frag, p[:, i], len(count)) for i in range(3)], axis=1) / safe[:, None]
        d0, d = p0 - c0[frag], p - c[frag]
        H = np.empty((len(count), 3, 3))
        for i in range(3):
            for j in range(3):
                H[:, i, j] = np.bincount(frag, d0[:, i] * d[:, j], len(count))
        U, S, Vt = np.linalg.svd(H)
        V = np.transpose(Vt, (0, 2, 1))
        flip = np.sign(np.linalg.det(V @ np.transpose(U, (0, 2, 1))))
        flip[flip == 0] = 1.0
        D = np.zeros((len(count), 3, 3))
        D[:, 0, 0] = D[:, 1, 1] = 1.0
        D[:, 2, 2] = flip
        R = V @ D @ np.transpose(U, (0, 2, 1))
        rigid = (count >= 3) & (S[:, 0] > 0) & (S[:, 1] > 1e-3 * S[:, 0])
        if k > 0:
            q = _turn(q, frames[k - 1]["angular_velocity"], f["angular_velocity"], times[k] - times[k - 1])
        by_fragment = matrix_to_quat(R[rigid])
        table = np.zeros((len(count), 4))
        table[rigid] = by_fragment
        sel = rigid[frag]
        q[sel] = table[frag[sel]]
        out.append(q.astype(np.float32))
    return out


def quat_to_euler_xyz(q):
    """Blender's XYZ Euler angles of quaternions (w, x, y, z)."""
    q = q.astype(float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # rotation matrix entries
    r00 = 1 - 2 * (y * y + z * z)
    r10 = 2 * (x * y + w * z)
    r20 = 2 * (x * z - w * y)
    r21 = 2 * (y * z + w * x)
    r22 = 1 - 2 * (x * x + y * y)
    r11 = 1 - 2 * (x * x + z * z)
    r12 = 2 * (y * z - w * x)
    sy = np.sqrt(r00 * r00 + r10 * r10)
    regular = sy > 1e-6
    ex = np.where(regular, np.arctan2(r21, r22), np.arctan2(-r12, r11))
    ey = np.arctan2(-r20, sy)
    ez = np.where(regular, np.arctan2(r10, r00), 0.0)
    return np.stack([ex, ey, ez], axis=1).astype(np.float32)


def default_camera(scene, points0, spacing, projectiles0, aspect):
    """The camera of mca's renderer (src/render/camera.cpp, make_camera): eye, target, up (world), vertical
    field of view in degrees. `points0`: the automata at frame 0; `projectiles0`: the balls' centres."""
    cam = scene.get("camera", {})
    up = up_axis(scene)
    fov = float(cam.get("fov", 40.0))
    lo, hi = points0.min(axis=0).astype(float), points0.max(axis=0).astype(float)
    h = 0.5 * spacing
    box_lo, box_hi = lo - h, hi + h
    target = np.array(cam["target"], float) if "target" in cam else 0.5 * (box_lo + box_hi)
    if "position" in cam:
        eye = np.array(cam["position"], float)
    else:
        def horizontal(hint):
            v = hint - np.dot(hint, up) * up
            if np.linalg.norm(v) < 1e-4:
                v = np.array([1.0, 0, 0]) if abs(up[0]) < 0.9 else np.array([0, 1.0, 0])
                v = v - np.dot(v, up) * up
            return v / np.linalg.norm(v)
        front = np.array([0.0, -1.0, 0.0])
        if len(projectiles0):
            front = projectiles0.astype(float).mean(axis=0) - target
        front = horizontal(front)
        side = np.cross(up, front)
        side /= np.linalg.norm(side)
        az, el = math.radians(35.0), math.radians(25.0)
        back = math.cos(el) * (math.cos(az) * front + math.sin(az) * side) + math.sin(el) * up
        f = -back
        r = np.cross(f, up)
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        tan_v = math.tan(math.radians(fov) / 2)
        tan_h = tan_v * aspect
        dist = 0.0
        for k in range(8):
            c = np.array([box_hi[0] if k & 1 else box_lo[0], box_hi[1] if k & 2 else box_lo[1],
                          box_hi[2] if k & 4 else box_lo[2]])
            d = c - target
            x, y, z = np.dot(d, r), np.dot(d, u), np.dot(d, f)
            dist = max(dist, 1.12 * abs(x) / tan_h - z, 1.12 * abs(y) / tan_v - z)
        eye = target + back * max(dist, 1e-3)
    return eye, target, up, fov


# ---------------------------------------------------------------------------------------------------------
# The run folder

def default_fps(frames):
    """The video's rate of `mca run --render` without --render-fps: frames / 4 within 10 to 30."""
    return min(max(math.floor(frames / 4.0 + 0.5), 10), 30)


def run_folder(path):
    """(the run folder, how to name it in messages) of what the user chose: the folder itself or a file in it
    (its automata.pvd, summary.json...). Raises RunError when the path is empty or does not exist."""
    if not path:
        raise RunError("no run folder given (the path is empty): choose the folder an `mca run` wrote (its --out)")
    full = os.path.abspath(path)
    path = path.rstrip("/" + os.sep) or path  # as given, less a trailing separator (a file browser's folder)
    if os.path.isdir(full):
        return full, path
    if os.path.isfile(full):
        folder = os.path.dirname(full)
        return folder, f"{folder} (the folder of {path})"
    if os.path.lexists(full):
        raise RunError(f"{path} is neither a folder nor a file; choose the folder an `mca run` wrote (its --out)")
    raise RunError(f"{path} does not exist; choose the folder an `mca run` wrote (its --out), or its automata.pvd")


def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _vector(v):
    return isinstance(v, list) and len(v) == 3 and all(_number(c) for c in v)


def check_scene(scene, path):
    """The scene.toml keys the importer reads, with the types and ranges mca accepts (docs/scene-format.md);
    RunError naming the file and the key otherwise."""
    def table(key, where=scene):
        t = where.get(key, {})
        if not isinstance(t, dict):
            raise RunError(f"{path}: {key} = {t!r} is not a table ([{key}]); fix the file (it should be the scene "
                           "exactly as mca ran it) or run mca again")
        return t

    def need(section, key, ok, what):
        t = table(section) if section else scene
        if key in t and not ok(t[key]):
            name = f"[{section}] {key}" if section else key
            raise RunError(f"{path}: {name} = {t[key]!r} is not {what}; fix the file (it should be the scene "
                           "exactly as mca ran it) or run mca again")

    need(None, "name", lambda v: isinstance(v, str), "a string")
    need("solver", "gravity", _vector, "a vector of 3 numbers, like [0.0, 0.0, -9.81]")
    need("ground", "enabled", lambda v: isinstance(v, bool), "true or false")
    need("ground", "height", _number, "a number (metres)")
    need("camera", "fov", lambda v: _number(v) and 5 <= v <= 150, "a number of degrees from 5 to 150")
    need("camera", "position", _vector, "a vector of 3 numbers (metres)")
    need("camera", "target", _vector, "a vector of 3 numbers (metres)")
    balls = scene.get("projectile", [])
    if not isinstance(balls, list) or not all(isinstance(b, dict) for b in balls):
        raise RunError(f"{path}: projectile is not a list of tables ([[projectile]]); fix the file (it should be "
                       "the scene exactly as mca ran it) or run mca again")


class Run:
    """What a run folder holds, read into numpy arrays.

    Attributes: dir, scene (the scene.toml as a dict), summary (dict or None), warnings (list of str),
    times (per frame, simulated seconds), frames (list of dicts: points, fragment, object, radius,
    angular_velocity, damage), projectiles (per frame: (centres (P, 3), radii (P,)) or None), spacing,
    fps, render_size, surface_files (list or empty), fragment_files ({id: path})."""

    def __init__(self, path, max_frames=None):
        check_dependencies()
        self.warnings = []
        self.dir, where = run_folder(path)
        pvd = os.path.join(self.dir, "automata.pvd")
        scene_file = os.path.join(self.dir, "scene.toml")
        if not os.path.lexists(pvd):
            if os.path.isfile(scene_file):
                raise RunError(f"{where} holds no frames (no automata.pvd): the run wrote none (output.vtk = false "
                               "or --no-vtk, or it stopped before its first frame); run it again with VTK frames")
            raise RunError(f"{where} is not an mca run folder (it has neither automata.pvd nor scene.toml); "
                           "choose the folder an `mca run` wrote (its --out)")
        self.scene = self._read_scene(scene_file)
        self.summary = self._read_summary()
        entries = read_pvd(pvd)
        if not entries:
            raise RunError(f"{pvd} lists no frames: the run stopped before its first frame; run it again")
        self.frame_count = len(entries)  # the run's, before max_frames
        if max_frames is not None:
            entries = entries[:max_frames]
        self.times = [t for t, _ in entries]
        wanted = {"fragment", "object", "radius", "angular_velocity", "damage", "displacement"}
        self.frames = []
        # Each frame's count checked against the run's before its arrays are read (summary.json's, else frame 0's).
        count = self.summary.get("automata") if self.summary else None
        expect = (count, "where summary.json says") if isinstance(count, int) and not isinstance(count, bool) else None
        for t, rel in entries:
            points, fields = read_vtu(os.path.join(self.dir, rel), wanted | {"orientation"}, expect=expect)
            expect = (len(points), "frame 0")
            missing = sorted(wanted - fields.keys())
            if missing:
                raise RunError(f"{os.path.join(self.dir, rel)} has no field {', '.join(missing)}: not a frame of "
                               "the automata written by mca")
            # Indices that size arrays (a fragment id of 2^31 made numpy allocate 16 GB): each in 0..N-1.
            for key in ("fragment", "object"):
                ids = np.asarray(fields[key])
                if ids.dtype.kind not in "iu":
                    raise RunError(f"{os.path.join(self.dir, rel)}: array '{key}' is of {ids.dtype}, not the "
                                   "integers mca writes (an id per automaton): the frame is damaged; run mca again")
                bad = np.flatnonzero((ids < 0) | (ids >= max(len(points), 1)))
                if len(bad):
                    raise RunError(f"{os.path.join(self.dir, rel)}: array '{key}' holds {ids[bad[0]]} at automaton "
                                   f"{bad[0]}, outside 0..{len(points) - 1} (an id per automaton): the frame is "
                                   "damaged; run mca again")
            self.frames.append(dict(points=points, **fields))
            if len(self.frames) == 1:
                self._check_frames_fit(len(entries), self.frame_count)
        # Frames of mca before the orientation was written: the rotations are reconstructed.
        self.has_orientation = all("orientation" in f for f in self.frames)
        if not self.has_orientation:
            self.warnings.append("the frames carry no orientation (written by an older mca): the cubes' rotations "
                                 "are reconstructed from the fragments' motion and the angular velocities")
        self.projectiles = self._read_projectiles(len(entries))
        entries = entries[:len(self.frames)]
        self.spacing = self._spacing()
        self.fps, self.render_size = self._render_options()
        self.surface_files = self._surface_files([frame_number(rel, k) for k, (_, rel) in enumerate(entries)])
        self.fragment_files = self._fragment_files()

    def _check_frames_fit(self, frames, run_frames):
        """The importer holds every frame it reads: frames as large as the first, more than a quarter of the
        machine's memory together, are refused before the second is read (30,000 frames of 4,800 automata
        grew to 6.8 GB and ended in a MemoryError blamed on a bug)."""
        memory = _memory_bytes()
        each = sum(np.asarray(a).nbytes for a in self.frames[0].values())
        if memory and frames * each > memory / 4:
            fit = max(1, int(memory / 4 // max(each, 1)))
            raise RunError(f"{frames:,} frames of {len(self.frames[0]['points']):,} automata would take about "
                           f"{frames * each / 1e9:.3g} GB of arrays, more than a quarter of this machine's "
                           f"{memory / 1e9:.3g} GB: import fewer frames (at most about {fit:,}: the importer's Frames "
                           "setting, or --frames N in mca_cli.py)"
                           + ("" if frames == run_frames else f"; the run has {run_frames:,}"))

    # -- the files around the frames
    def _read_scene(self, scene_file):
        if not os.path.lexists(scene_file):
            self.warnings.append(f"{scene_file} is missing: the ground, the camera and the up axis take mca's "
                                 "defaults, and every automaton is drawn (the lattice is not known)")
            return {}
        try:
            scene = tomllib.loads(_read_bytes(scene_file, f"{scene_file} is missing", SCENE_MAX).decode("utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
            raise RunError(f"{scene_file}: {e}; it should be the scene exactly as run: run mca again")
        check_scene(scene, scene_file)
        return scene

    def _read_summary(self):
        path = os.path.join(self.dir, "summary.json")
        if not os.path.lexists(path):
            self.warnings.append(f"{path} is missing: the run is still going or was killed; importing the frames "
                                 "written so far")
            return None
        try:
            summary = json.loads(_read_bytes(path, f"{path} is missing").decode("utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise RunError(f"{path} is not complete JSON ({e}): run mca again")
        if not isinstance(summary, dict):
            raise RunError(f"{path} is not the summary mca writes (a JSON object, not {type(summary).__name__}): "
                           "run mca again")
        for key, ok, what in (("status", lambda v: isinstance(v, str), "a string"),
                              ("simulated_time", _number, "a number"),
                              ("spacing", lambda v: _number(v) and 1e-9 <= v <= 1e9,
                               "a spacing from 1e-9 to 1e9 m (solver.spacing's range)")):
            if key in summary and not ok(summary[key]):
                raise RunError(f"{path}: \"{key}\" is {summary[key]!r}, not {what}: not the summary mca writes; "
                               "run mca again")
        if summary.get("status") not in (None, "finished"):
            self.warnings.append(f"the run stopped early ({summary.get('status')} at "
                                 f"{summary.get('simulated_time', 0):.4g} s): importing the frames it wrote")
        return summary

    def _read_projectiles(self, frames):
        pvd = os.path.join(self.dir, "projectiles.pvd")
        if not os.path.lexists(pvd):
            balls = len(self.scene.get("projectile", []))
            if balls:
                self.warnings.append(f"{pvd} is missing, though the scene has {balls} projectile"
                                     f"{'s' if balls > 1 else ''}: the balls are left out; copy the run's whole "
                                     "folder or run mca again")
            return None
        entries = read_pvd(pvd)[:frames]
        if len(entries) < frames:
            if self.summary is not None or not entries:
                raise RunError(f"{pvd} lists {len(entries)} frames, automata.pvd {frames}: the run folder is "
                               "incomplete; run mca again")
            # A run still going writes automata.pvd before projectiles.pvd: the frames both list are taken.
            self.warnings.append(f"{pvd} lists {len(entries)} frames, automata.pvd {frames} (the run is still "
                                 f"writing): importing the first {len(entries)}")
            del self.frames[len(entries):]
            del self.times[len(entries):]
        out = []
        for _, rel in entries:
            points, fields = read_vtu(os.path.join(self.dir, rel), {"radius"}, "projectiles.pvd")
            if "radius" not in fields:
                raise RunError(f"{os.path.join(self.dir, rel)} has no field radius")
            bad = np.flatnonzero(~(np.asarray(fields["radius"]) > 0))
            if len(bad):
                raise RunError(f"{os.path.join(self.dir, rel)}: array 'radius' holds {fields['radius'][bad[0]]} at "
                               f"projectile {bad[0]}: mca writes balls of a positive radius; the frame is damaged: "
                               "run mca again")
            out.append((points, fields["radius"]))
        return out

    def _spacing(self):
        if self.summary and self.summary.get("spacing", 0) > 0:
            return float(self.summary["spacing"])
        # a lattice automaton's contact radius is half the spacing
        r = self.frames[0]["radius"]
        return float(2.0 * np.median(r)) if len(r) else 1.0

    def _render_options(self):
        size = (1280, 720)
        fps = default_fps(self.frame_count)
        path = os.path.join(self.dir, "render", "render.json")
        if os.path.lexists(path):
            try:
                r = json.loads(_read_bytes(path, f"{path} is missing", _HEAD_MAX).decode("utf-8"))  # (mca: 100 bytes)
                if not isinstance(r, dict):
                    raise ValueError(f"a JSON {type(r).__name__}, not an object")
                w, h, f = r.get("width"), r.get("height"), r.get("fps")
                for key, v in (("width", w), ("height", h)):
                    if not (isinstance(v, int) and not isinstance(v, bool) and 16 <= v <= 8192):
                        raise ValueError(f"{key} {v!r} is not a whole number of pixels from 16 to 8192 (what mca "
                                         "draws)")
                if f is not None and not (_number(f) and 0 <= f <= 240):
                    raise ValueError(f"fps {f!r} is not a rate from 0 (the default) to 240")
                size = (w, h)
                if f:
                    fps = float(f)
            except (RunError, ValueError) as e:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
                size = (1280, 720)
                self.warnings.append(f"{path} is not the render options mca writes ({e}): using 1280x720 at "
                                     f"{fps:g} frames/s")
        return fps, size

    def _surface_files(self, numbers):
        """The bound surface of each frame, by the frame's number (a resumed run's collections leave out a
        frame whose files were lost, and its surface file would have been paired with the next frame)."""
        folder = os.path.join(self.dir, "surface")
        if not os.path.isdir(folder):
            return []
        files = []
        for k in numbers:
            for ext in ("ply", "obj"):
                p = os.path.join(folder, f"surface_{k:06d}.{ext}")
                if os.path.isfile(p):
                    files.append(p)
                    break
            else:
                raise RunError(f"{folder} has no surface file for frame {k} (surface_{k:06d}.ply or .obj): the run "
                               "folder is incomplete; run mca again")
        return files

    def _fragment_files(self):
        folder = os.path.join(self.dir, "fragments")
        out = {}
        if os.path.isdir(folder):
            for name in sorted(os.listdir(folder)):
                m = re.fullmatch(r"fragment_(\d{1,10})\.ply", name)
                if m and int(m.group(1)) < 2 ** 31:  # (a fragment number mca writes; others are not its files)
                    out[int(m.group(1))] = os.path.join(folder, name)
        self._check_fragment_files(out)
        return out

    def _check_fragment_files(self, found):
        """A finished run's meshes are those of the fragments of fragments.csv with more than
        output.fragment_min_automata automata: one missing is said (it was left out without a word)."""
        output = self.scene.get("output", {}) if self.scene else {}
        if not (self.summary and self.summary.get("status") == "finished" and isinstance(output, dict) and
                output.get("fragments") is True):
            return
        least = output.get("fragment_min_automata", 8)
        path = os.path.join(self.dir, "fragments.csv")
        try:
            rows = _read_bytes(path, f"{path} is missing").decode("utf-8").splitlines()[1:]
            sizes = {int(r.split(",")[0]): int(r.split(",")[1]) for r in rows if r.strip()}
        except (RunError, ValueError, IndexError):
            return  # (the meshes are imported as found; fragments.csv is not the importer's to judge)
        missing = sorted(i for i, n in sizes.items() if n > least and i not in found)
        if missing:
            names = ", ".join(f"fragment_{i:03d}.ply" for i in missing[:3]) + (", ..." if len(missing) > 3 else "")
            self.warnings.append(f"{os.path.join(self.dir, 'fragments')} lacks {len(missing)} of the "
                                 f"{sum(n > least for n in sizes.values())} fragment meshes fragments.csv calls for "
                                 f"({names}): they are left out; run mca again to write them")

    # -- derived per frame
    def colours(self, k):
        """uint8 RGB per automaton at frame k: the renderer's fragment colouring."""
        f = self.frames[k]
        return fragment_colours(f["fragment"], f["object"])

    def initial_positions(self):
        f = self.frames[0]
        return f["points"].astype(float) - f["displacement"].astype(float)

    def exposed(self):
        """Per frame, a bool per automaton: the automata the renderer draws (fewer than six intact links):
        those on their object's surface at the start and those with a broken link. On the random lattice
        (solver.lattice = "random"), whose automata have no six neighbours at the spacing, every one; also
        where the lattice is not known (no scene.toml: the cubic rule left holes in a random lattice's faces,
        mca's default)."""
        if self.scene.get("solver", {}).get("lattice") != "cubic":
            return [np.ones(len(f["damage"]), bool) for f in self.frames]
        start = exposed_at_start(self.initial_positions(), self.frames[0]["object"], self.spacing)
        return [start | (f["damage"] > 0) for f in self.frames]

    def unbound_automata(self):
        """A bool per automaton: those of objects whose triangles the bound surface does not carry (a box, a
        sphere, a cylinder: not shape = "mesh"), which the renderer draws as cubes beside the surface. None
        where the scene is not known (no scene.toml)."""
        objects = self.scene.get("object") if self.scene else None
        if not isinstance(objects, list):
            return None
        meshes = np.array([isinstance(o, dict) and o.get("shape") == "mesh" for o in objects] + [False], bool)
        ids = np.minimum(np.asarray(self.frames[0]["object"]), len(objects))
        return ~meshes[ids]

    def rotations(self):
        """Per frame, the automata's orientations (w, x, y, z): the frames' own, else reconstructed."""
        if self.has_orientation:
            return [f["orientation"] for f in self.frames]
        return automaton_rotations(self.initial_positions(), self.frames, self.times)

    def camera(self):
        w, h = self.render_size
        balls = self.projectiles[0][0] if self.projectiles else np.zeros((0, 3))
        return default_camera(self.scene, self.frames[0]["points"], self.spacing, balls, w / h)

    def ground(self):
        """(height along up, up) when the scene has a ground, else None."""
        g = self.scene.get("ground", {})
        if not g.get("enabled", False):
            return None
        return float(g.get("height", 0.0)), up_axis(self.scene)
