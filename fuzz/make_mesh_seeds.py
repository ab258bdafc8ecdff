#!/usr/bin/env python3
"""Writes the mesh seeds of fuzz_mesh into fuzz/seeds/mesh/ (run from anywhere: python3 fuzz/make_mesh_seeds.py).

Each seed is a small mesh file (a tetrahedron, one quad-faced cube) with one selector byte put in front:
fuzz_mesh reads the format from byte 0 (byte % 6: 0 obj, 1 ply, 2 stl, 3 off, 4 gltf, 5 glb) and passes the rest to
mca::mesh::read_mesh_memory. The selectors used are the ASCII digits '0'..'5' (0x30..0x35), so a seed reads as
text: "3OFF\n4 4 0\n..." is an OFF file.
"""
import base64
import json
import os
import struct

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "seeds", "mesh")
SELECTOR = {"obj": b"0", "ply": b"1", "stl": b"2", "off": b"3", "gltf": b"4", "glb": b"5"}

# A unit tetrahedron, triangles facing outward.
V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def normal(f):
    a, b, c = (V[i] for i in f)
    u = [b[k] - a[k] for k in range(3)]
    w = [c[k] - a[k] for k in range(3)]
    n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    length = sum(x * x for x in n) ** 0.5
    return [x / length for x in n]


def write(name, ext, body):
    if isinstance(body, str):
        body = body.encode()
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(SELECTOR[ext] + body)


def main():
    os.makedirs(OUT, exist_ok=True)
    g = lambda x: f"{x:g}"

    write("tetra.off", "off", "OFF\n4 4 0\n" + "".join(" ".join(map(g, v)) + "\n" for v in V)
          + "".join("3 " + " ".join(map(str, f)) + "\n" for f in F))

    write("tetra.obj", "obj", "# tetrahedron\no tetra\n" + "".join("v " + " ".join(map(g, v)) + "\n" for v in V)
          + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in F))
    # Quads (triangulated by the loader), negative (relative) indices, normals and texture coordinates.
    write("cube_quads.obj", "obj", """o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 1
vt 0 0
g sides
f 1/1/1 4/1/1 3/1/1 2/1/1
f 5//1 6//1 7//1 8//1
f -8 -7 -3 -4
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
""")

    write("tetra_ascii.ply", "ply", "ply\nformat ascii 1.0\ncomment tetrahedron\nelement vertex 4\n"
          "property float x\nproperty float y\nproperty float z\nelement face 4\n"
          "property list uchar int vertex_indices\nend_header\n"
          + "".join(" ".join(map(g, v)) + "\n" for v in V)
          + "".join("3 " + " ".join(map(str, f)) + "\n" for f in F))
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<3f", *v) for v in V) + b"".join(struct.pack("<B3i", 3, *f) for f in F)
    write("tetra_binary.ply", "ply", header + body)

    write("tetra_ascii.stl", "stl", "solid tetra\n" + "".join(
        "facet normal " + " ".join(map(g, normal(f))) + "\n outer loop\n"
        + "".join("  vertex " + " ".join(map(g, V[i])) + "\n" for i in f) + " endloop\nendfacet\n" for f in F)
        + "endsolid tetra\n")
    # Binary STL: an 80-byte header that does not start with "solid", the triangle count, 50 bytes per triangle.
    stl = b"binary STL tetrahedron".ljust(80, b" ") + struct.pack("<I", len(F))
    for f in F:
        stl += struct.pack("<3f", *normal(f)) + b"".join(struct.pack("<3f", *V[i]) for i in f) + struct.pack("<H", 0)
    write("tetra_binary.stl", "stl", stl)

    # glTF 2.0: float positions and unsigned short indices in one buffer.
    positions = b"".join(struct.pack("<3f", *v) for v in V)
    indices = b"".join(struct.pack("<3H", *f) for f in F)
    buffer = positions + indices

    def gltf(uri):
        doc = {
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0, "translation": [0.5, 0, 0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
            "buffers": [{"byteLength": len(buffer)}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": len(positions), "target": 34962},
                {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices), "target": 34963},
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": len(V), "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]},
                {"bufferView": 1, "componentType": 5123, "count": 3 * len(F), "type": "SCALAR"},
            ],
        }
        if uri:
            doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buffer).decode()
        return json.dumps(doc, separators=(",", ":")).encode()

    write("tetra.gltf", "gltf", gltf(uri=True))
    js = gltf(uri=False)
    js += b" " * (-len(js) % 4)
    binchunk = buffer + b"\0" * (-len(buffer) % 4)
    glb = (struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(binchunk))
           + struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binchunk), b"BIN\0") + binchunk)
    write("tetra.glb", "glb", glb)


if __name__ == "__main__":
    main()
