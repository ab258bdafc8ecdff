"""Building Blender objects from a run folder read by reader.Run.

Each frame of the automata is an object of its own, shown (in the viewport and in renders) at its frame
only by keyframes of its visibility: the exposed automata as points with a geometry-nodes modifier that
puts a cube of the spacing on each, turned by its rotation, or the bound surface's triangles. So the
animation lives in the .blend itself (no handler, no add-on needed to play or render it), playing only
switches which object is shown (each is evaluated once, then drawn from Blender's cache), and exporters
write at each frame the object shown.

Colours: the `mca_colour` colour attribute (linear RGBA) of every object holds the renderer's `fragment`
colouring (README, "Pictures and video"); the material "mca colour" reads it, and so does the Workbench
with its colour set to Attribute.
"""

import math
import os
import time

import bpy
import bmesh
import numpy as np
from mathutils import Matrix, Vector

from . import reader

COLOUR = "mca_colour"
ROTATION = "mca_rotation"
BALL_COLOUR = (205, 30, 30)  # the renderer's projectiles
BACKGROUND = (34, 37, 43)  # the renderer's background


class Imported:
    """What import_run made: the collection, the objects by role and the run it read."""

    def __init__(self, run):
        self.run = run
        self.collection = None
        self.automata = None  # the collection of the frames' objects
        self.frame_objects = []  # the object of each frame
        self.cubes = None  # with a bound surface, the collection of the cubes of objects it does not carry
        self.cube_objects = []  # their object of each frame
        self.projectiles = []
        self.ground = None
        self.camera = None
        self.light = None
        self.fragments = []
        self.seconds = 0.0

    @property
    def frames(self):
        return len(self.run.frames)


# ---------------------------------------------------------------------------------------------------------

def _colour_material():
    # The one an earlier import made (marked as the importer's: a material of the user's that happens to be
    # named "mca colour" is left alone, and the new one is named "mca colour.001").
    mat = next((m for m in bpy.data.materials if m.get("mca_colour_material")), None)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new("mca colour")
    mat["mca_colour_material"] = 1
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes.get("Principled BSDF")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = COLOUR
    attr.location = (-300, 300)
    nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.8
    return mat


def _set_colour(mesh, domain, rgb_bytes):
    """The colour attribute of a mesh from uint8 RGB per element of `domain`, made active."""
    lin = reader.srgb_to_linear(rgb_bytes)
    rgba = np.ones((len(lin), 4), np.float32)
    rgba[:, :3] = lin
    attr = mesh.color_attributes.new(COLOUR, "FLOAT_COLOR", domain)
    attr.data.foreach_set("color", rgba.ravel())
    mesh.color_attributes.active_color = attr
    return attr


def _attribute(mesh, name, kind, domain, values):
    attr = mesh.attributes.new(name, kind, domain)
    attr.data.foreach_set("vector" if kind == "FLOAT_VECTOR" else "value", np.ascontiguousarray(values).ravel())
    return attr


def _enabled(sockets):
    return [s for s in sockets if s.enabled]


def _cube_tree(spacing):
    """Geometry nodes: a cube of the spacing on each point, turned by mca_rotation, realized (so that
    exporters and renderers get a mesh), with the material "mca colour"."""
    tree = bpy.data.node_groups.new("mca cubes", "GeometryNodeTree")
    tree.inputs.new("NodeSocketGeometry", "Geometry")
    tree.outputs.new("NodeSocketGeometry", "Geometry")
    n, link = tree.nodes, tree.links.new
    gin, gout = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    cube = n.new("GeometryNodeMeshCube")
    cube.inputs["Size"].default_value = (spacing, spacing, spacing)
    rot = n.new("GeometryNodeInputNamedAttribute")
    rot.data_type = "FLOAT_VECTOR"
    rot.inputs["Name"].default_value = ROTATION
    inst = n.new("GeometryNodeInstanceOnPoints")
    link(gin.outputs[0], inst.inputs["Points"])
    link(cube.outputs["Mesh"], inst.inputs["Instance"])
    link(_enabled(rot.outputs)[0], inst.inputs["Rotation"])
    realize = n.new("GeometryNodeRealizeInstances")
    link(inst.outputs["Instances"], realize.inputs["Geometry"])
    material = n.new("GeometryNodeSetMaterial")
    material.inputs["Material"].default_value = _colour_material()
    link(realize.outputs["Geometry"], material.inputs["Geometry"])
    link(material.outputs["Geometry"], gout.inputs[0])
    for k, node in enumerate(n):
        node.location = (200 * k, 0)
    return tree


def _object(name, data, collection):
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    return obj


def _shown_at(obj, frame, last):
    """obj is visible (viewport and render) at `frame` only: keyframes of hide_viewport and hide_render."""
    obj.hide_viewport = obj.hide_render = frame != 0
    obj.animation_data_create()
    action = bpy.data.actions.new(obj.name + " visibility")
    obj.animation_data.action = action
    keys = [(f, float(f != frame)) for f in (frame - 1, frame, frame + 1) if 0 <= f <= last]
    co = np.array(keys, np.float32).ravel()
    for path in ("hide_viewport", "hide_render"):
        fc = action.fcurves.new(path)
        fc.keyframe_points.add(len(keys))
        fc.keyframe_points.foreach_set("co", co)
        fc.keyframe_points.foreach_set("interpolation", np.zeros(len(keys), np.int32))  # CONSTANT
        fc.update()


# ---------------------------------------------------------------------------------------------------------
# The automata: one object per frame, shown at its frame only. Each holds its frame's geometry, so playing
# the timeline only switches which object is shown: Blender evaluates each once and then draws it from its
# cache (a frame's switch takes well under a millisecond).

def _automata_cubes(run, collection, only=None):
    """Per frame, a point per exposed automaton (of those `only` marks, where given) with its rotation (XYZ
    Euler), colour, fragment, damage and index; the geometry nodes put a cube of the spacing on each."""
    exposed = run.exposed()
    rotations = run.rotations()
    tree = _cube_tree(run.spacing)
    last = len(run.frames) - 1
    out = []
    for k, f in enumerate(run.frames):
        sel = np.nonzero(exposed[k] if only is None else exposed[k] & only)[0]
        name = f"mca automata {k:06d}"
        mesh = bpy.data.meshes.new(name)
        mesh.vertices.add(len(sel))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(f["points"][sel], np.float32).ravel())
        _attribute(mesh, ROTATION, "FLOAT_VECTOR", "POINT", reader.quat_to_euler_xyz(rotations[k][sel]))
        _attribute(mesh, "fragment", "INT", "POINT", f["fragment"][sel].astype(np.int32))
        _attribute(mesh, "damage", "FLOAT", "POINT", f["damage"][sel].astype(np.float32))
        _attribute(mesh, "automaton", "INT", "POINT", sel.astype(np.int32))
        _set_colour(mesh, "POINT", run.colours(k)[sel])
        mesh.update()
        obj = _object(name, mesh, collection)
        obj["mca_frame"] = k
        obj.modifiers.new("mca cubes", "NODES").node_group = tree
        _shown_at(obj, k, last)
        out.append(obj)
    return out


def _surface(run, collection):
    """Per frame, the bound surface: its triangles in the colour of their fragment."""
    last = len(run.frames) - 1
    out = []
    material = _colour_material()
    for k, path in enumerate(run.surface_files):
        v, f, values = reader.read_obj(path) if path.endswith(".obj") else reader.read_ply(path)
        if values is None:
            raise reader.RunError(f"{path} has no fragment number per face: not a surface written by mca")
        autom = run.frames[k]
        # a fragment's colour is that of its automata (all of them share it)
        table = np.zeros((int(max(autom["fragment"].max(), values.max() if len(values) else 0)) + 1, 3), np.uint8)
        table[autom["fragment"]] = run.colours(k)
        name = f"mca surface {k:06d}"
        mesh = bpy.data.meshes.new(name)
        mesh.vertices.add(len(v))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(v, np.float32).ravel())
        mesh.loops.add(3 * len(f))
        mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(f, np.int32).ravel())
        mesh.polygons.add(len(f))
        mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(f), 3, dtype=np.int32))
        mesh.polygons.foreach_set("loop_total", np.full(len(f), 3, np.int32))
        mesh.update(calc_edges=True)
        _attribute(mesh, "fragment", "INT", "FACE", values.astype(np.int32))
        _set_colour(mesh, "CORNER", np.repeat(table[values], 3, axis=0))
        mesh.materials.append(material)
        obj = _object(name, mesh, collection)
        obj["mca_frame"] = k
        _shown_at(obj, k, last)
        out.append(obj)
    return out


def _sphere_mesh(name, rgb):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=1.0)
    for f in bm.faces:
        f.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    _set_colour(mesh, "CORNER", np.tile(np.array(rgb, np.uint8), (len(mesh.loops), 1)))
    mesh.materials.append(_colour_material())
    return mesh


def _keyframes(obj, path, values, frames):
    """Keyframes of obj.<path> (values: frames x components), linear between frames."""
    if obj.animation_data is None:
        obj.animation_data_create()
    if obj.animation_data.action is None:
        obj.animation_data.action = bpy.data.actions.new(obj.name + " motion")
    action = obj.animation_data.action
    for c in range(values.shape[1]):
        fc = action.fcurves.new(path, index=c)
        fc.keyframe_points.add(len(frames))
        co = np.empty((len(frames), 2), np.float32)
        co[:, 0] = frames
        co[:, 1] = values[:, c]
        fc.keyframe_points.foreach_set("co", co.ravel())
        fc.keyframe_points.foreach_set("interpolation", np.full(len(frames), 1, np.int32))  # LINEAR
        fc.update()


def _projectiles(run, collection):
    if not run.projectiles:
        return []
    count = len(run.projectiles[0][0])
    mesh = _sphere_mesh("mca projectile", BALL_COLOUR)
    frames = np.arange(len(run.projectiles), dtype=np.float32)
    out = []
    for p in range(count):
        obj = _object(f"mca projectile {p}", mesh, collection)
        centres = np.array([c[p] for c, _ in run.projectiles], np.float32)
        r = float(run.projectiles[0][1][p])
        obj.scale = (r, r, r)
        obj.location = centres[0]
        _keyframes(obj, "location", centres, frames)
        obj["mca_radius"] = r
        out.append(obj)
    return out


def _ground(run, collection, eye, target):
    """The ground as the renderer draws it: a square around the point under the target, 12 viewing distances
    across each way, checkered in tiles of a round size near a tenth of the viewing distance, fading into the
    background from 2.1 to 6 viewing distances from the camera."""
    g = run.ground()
    if g is None:
        return None
    height, up = g
    up = np.asarray(up, float)
    a = np.cross(up, [1.0, 0, 0] if abs(up[0]) < 0.9 else [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    target, eye = np.asarray(target, float), np.asarray(eye, float)
    centre = target - np.dot(target, up) * up + height * up
    dist = float(np.linalg.norm(target - eye))
    reach = 12.0 * dist + 10.0 * run.spacing
    tile = 10.0 ** round(math.log10(0.15 * dist)) if dist > 0 else 1.0
    while 2 * reach / tile > 240:  # at most 240 x 240 tiles
        tile *= 2
    count = int(math.ceil(2 * reach / tile))
    # tiles on the grid of multiples of `tile` along a and b, as the renderer's checker
    lo_a = math.floor((np.dot(centre, a) - reach) / tile)
    lo_b = math.floor((np.dot(centre, b) - reach) / tile)
    ia, ib = np.meshgrid(np.arange(count + 1), np.arange(count + 1), indexing="ij")
    coord_a, coord_b = (lo_a + ia) * tile, (lo_b + ib) * tile
    verts = coord_a[..., None] * a + coord_b[..., None] * b + (np.dot(centre, up)) * up
    verts = verts.reshape(-1, 3).astype(np.float32)
    fa, fb = np.meshgrid(np.arange(count), np.arange(count), indexing="ij")
    v0 = (fa * (count + 1) + fb).ravel()
    quads = np.stack([v0, v0 + count + 1, v0 + count + 2, v0 + 1], axis=1).astype(np.int32)
    checker = ((lo_a + fa + lo_b + fb) % 2).ravel()
    light = np.array([0.41, 0.405, 0.39]) * 255
    dark = np.array([0.36, 0.355, 0.34]) * 255
    rgb = np.where(checker[:, None] == 1, light, dark)
    mid = verts[quads].mean(axis=1)
    fade = np.clip((np.linalg.norm(mid - eye, axis=1) - 0.35 * 6 * dist) / (0.65 * 6 * dist), 0, 1)
    fade = fade * fade * (3 - 2 * fade)  # smoothstep
    rgb = (1 - fade[:, None]) * rgb + fade[:, None] * np.array(BACKGROUND, float)
    mesh = bpy.data.meshes.new("mca ground")
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", verts.ravel())
    mesh.loops.add(4 * len(quads))
    mesh.loops.foreach_set("vertex_index", quads.ravel())
    mesh.polygons.add(len(quads))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 4 * len(quads), 4, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(quads), 4, np.int32))
    mesh.update(calc_edges=True)
    _set_colour(mesh, "CORNER", np.repeat(np.round(rgb).astype(np.uint8), 4, axis=0))
    mesh.materials.append(_colour_material())
    obj = _object("mca ground", mesh, collection)
    obj["mca_height"] = height
    obj["mca_tile"] = tile
    return obj


def _camera(run, collection, scene):
    eye, target, up, fov = run.camera()
    cam = bpy.data.cameras.new("mca camera")
    cam.sensor_fit = "VERTICAL"
    cam.angle_y = math.radians(fov)
    f = Vector(target - eye).normalized()
    u = Vector(up)
    if abs(f.dot(u)) > 0.999:  # looking along the up axis
        u = Vector((0, 1, 0)) - Vector((0, 1, 0)).dot(Vector(up)) * Vector(up)
    x = f.cross(u).normalized()
    y = x.cross(f)
    rot = Matrix((x, y, -f)).transposed()
    dist = (Vector(target) - Vector(eye)).length
    lo = run.frames[0]["points"].min(axis=0)
    hi = run.frames[0]["points"].max(axis=0)
    radius = 0.5 * float(np.linalg.norm(hi - lo)) + run.spacing
    cam.clip_start = max(1e-3, min(0.5 * (dist - radius), 0.05 * dist))
    cam.clip_end = 40.0 * (dist + radius)
    obj = _object("mca camera", cam, collection)
    obj.matrix_world = Matrix.Translation(Vector(eye)) @ rot.to_4x4()
    scene.camera = obj
    w, h = run.render_size
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    return obj, eye, target


def _sun(collection, eye, target, up):
    """The renderer's key light for Eevee and Cycles: from above, over the camera's left shoulder."""
    fwd = Vector(target - eye).normalized()
    u = Vector(up)
    right = fwd.cross(u).normalized()
    light = (-0.8 * fwd - 0.4 * right + 0.8 * u).normalized()
    sun = bpy.data.lights.new("mca light", "SUN")
    sun.energy = 3.0
    obj = _object("mca light", sun, collection)
    obj.rotation_euler = light.to_track_quat("Z", "Y").to_euler()  # a sun shines along its -Z
    return obj


def _fragment_meshes(run, collection):
    """fragments/fragment_NNN.ply: closed meshes of the fragments at the end of the run, NNN their id in
    fragments.csv (the numbering of the last frame), coloured as their automata in the last frame."""
    if not run.fragment_files:
        return []
    sub = bpy.data.collections.new("mca fragments")
    collection.children.link(sub)
    last = run.frames[-1]
    table = np.zeros((int(last["fragment"].max()) + 1, 3), np.uint8)
    table[last["fragment"]] = run.colours(len(run.frames) - 1)
    out = []
    for fid, path in run.fragment_files.items():
        v, f, _ = reader.read_ply(path)
        mesh = bpy.data.meshes.new(f"mca fragment {fid:03d}")
        mesh.from_pydata(v.tolist(), [], f.tolist())
        rgb = table[fid] if fid < len(table) else reader.MAIN_BODY
        _set_colour(mesh, "CORNER", np.tile(rgb, (len(mesh.loops), 1)))
        mesh.materials.append(_colour_material())
        obj = _object(f"mca fragment {fid:03d}", mesh, sub)
        obj["mca_fragment"] = fid
        out.append(obj)
    # They sit where the fragments end: shown on demand, over the animation's last frame.
    sub.hide_viewport = True
    sub.hide_render = True
    return out


# The kinds of Blender data an import makes, objects first (each removed before what it uses).
_MADE = ("objects", "collections", "meshes", "materials", "node_groups", "cameras", "lights", "actions", "worlds",
         "images", "curves")
# The scene's settings an import sets.
_SET = ("frame_start", "frame_end", "camera", "world", "render.fps", "render.fps_base", "display.shading.color_type",
        "display_settings.display_device", "view_settings.view_transform")


def _get(owner, dotted):
    for name in dotted.split("."):
        owner = getattr(owner, name)
    return owner


def _set(owner, dotted, value):
    *path, name = dotted.split(".")
    for p in path:
        owner = getattr(owner, p)
    setattr(owner, name, value)


def _undo_on_failure(scene):
    """What the data and `scene` hold now; the returned function takes back whatever an import added and
    set since (a failed import must not leave half a run in the file, nor a second try's .001 copies)."""
    before = {kind: {d.as_pointer() for d in getattr(bpy.data, kind)} for kind in _MADE}
    settings = {key: _get(scene, key) for key in _SET}

    def undo():
        for kind in _MADE:
            data = getattr(bpy.data, kind)
            for d in [d for d in data if d.as_pointer() not in before[kind]]:
                data.remove(d)
        for key, value in settings.items():
            try:
                _set(scene, key, value)
            except (AttributeError, ReferenceError, TypeError, ValueError):
                pass  # (a setting that cannot be put back as it was stays as the import left it)

    return undo


def import_run(context, path, max_frames=None):
    """Reads the run folder `path` and builds it into the current scene; returns an Imported. Raises
    reader.RunError with a message for the user; an import that fails leaves the file as it was."""
    start = time.perf_counter()
    run = reader.Run(path, max_frames=max_frames)
    undo = _undo_on_failure(context.scene)
    try:
        return _build(context, run, start)
    except BaseException:
        undo()
        raise


def _build(context, run, start):
    scene = context.scene
    result = Imported(run)
    name = run.scene.get("name") or os.path.basename(run.dir.rstrip(os.sep))
    coll = bpy.data.collections.new(f"mca {name}")
    scene.collection.children.link(coll)
    result.collection = coll
    coll["mca_run"] = run.dir
    coll["mca_times"] = list(map(float, run.times))
    coll["mca_spacing"] = run.spacing

    # The timeline: one Blender frame per output frame, at the rate of mca's video.
    scene.frame_start = 0
    scene.frame_end = len(run.frames) - 1
    fps = run.fps
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps

    result.automata = bpy.data.collections.new("mca surface" if run.surface_files else "mca automata")
    coll.children.link(result.automata)
    result.frame_objects = (_surface if run.surface_files else _automata_cubes)(run, result.automata)
    result.automata["mca_frames"] = len(run.frames)
    # Objects that are not meshes have no triangles in the bound surface: cubes, as the renderer draws them.
    unbound = run.unbound_automata() if run.surface_files else None
    if unbound is not None and unbound.any():
        result.cubes = bpy.data.collections.new("mca automata")
        coll.children.link(result.cubes)
        result.cube_objects = _automata_cubes(run, result.cubes, unbound)
        result.cubes["mca_frames"] = len(run.frames)
    result.projectiles = _projectiles(run, coll)
    result.camera, eye, target = _camera(run, coll, scene)
    result.ground = _ground(run, coll, eye, target)
    result.light = _sun(coll, eye, target, reader.up_axis(run.scene))
    result.fragments = _fragment_meshes(run, coll)

    # Looks: the renderer's background; the Workbench shows the colour attribute; plain colours.
    if scene.world is None:
        scene.world = bpy.data.worlds.new("World")
    bg = reader.srgb_to_linear(np.array([BACKGROUND], np.uint8))[0]
    scene.world.color = tuple(bg)
    if scene.world.use_nodes:
        node = scene.world.node_tree.nodes.get("Background")
        if node is not None:
            node.inputs["Color"].default_value = (*bg, 1.0)
    scene.display.shading.color_type = "VERTEX"
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.view_transform = "Standard"
    scene.frame_set(scene.frame_start)
    result.seconds = time.perf_counter() - start
    return result
