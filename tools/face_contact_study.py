#!/usr/bin/env python3
"""How two faces of automata share a load when pressed together: the study behind mca's contacts that
see faces (docs/model-notes.md, "Faces touch as faces"; ModelView::face_pair).

Two square faces of n x n cells (spacing 1) face each other, their automata in the planes of their cells'
centres: at the cells' centres (the cubic lattice's faces), at a random point of the cell in the face's
plane (the random lattice's), or a cubic face turned against the other. They are pressed together until
the summed normal force is that of a mean overlap of `--overlap` spacings a site (what the ground, which
meets every site along its normal, gives each). Two contact laws, the spring per unit overlap being 1:

- sphere: mca's law of automata as spheres (radius 1/2 each), that faces had before: a pair touches
  where its sites are nearer than 1, along the line between them; the force has a part along the faces,
  which pushes the face layers sideways;
- face (mca's since): along the faces' normal, a pair's spring weighted by the overlap of squares of the
  spacing centred on the two sites (bilinear: on two grids the weights of a site sum to 1, whatever their
  offset).

Printed per case, over the faces' inner sites (five cells from the edges): the largest normal force of a
site over the mean, the share of sites that carry none, the 90th percentile over the mean, and the forces
along the faces over those along the normal. (2026-12-07, n = 40, overlap 0.01: sphere contacts leave
68 % of a random face's sites without load and put 8.4 times the mean on one, with 0.19 of the normal
force along the faces; weighted face contacts 2.3 times and none along the faces, 1.03 times between
turned grids; weights from the cells' centres instead of the sites would make a random face a grid.)

    python3 tools/face_contact_study.py [--cells 40] [--overlap 0.01] [--turn 10] [--seed 1]
"""

import argparse

import numpy as np


def face(n, random, rng):
    """Sites of an n x n face in its plane: cells' centres, or a random point of each cell."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    u = rng.random((n, n)) if random else np.full((n, n), 0.5)
    v = rng.random((n, n)) if random else np.full((n, n), 0.5)
    return np.stack([i + u, j + v], -1).reshape(-1, 2)


def forces(a, b, law, h):
    """Per site of `a`: the summed normal and lateral forces of its contacts with `b`, the faces' planes of
    sites `h` apart."""
    d = b[None, :, :] - a[:, None, :]
    lateral2 = (d ** 2).sum(-1)
    if law == "sphere":
        dist = np.sqrt(lateral2 + h * h)
        overlap = np.clip(1 - dist, 0, None)
        safe = np.where(dist > 0, dist, 1)
        return (overlap * h / safe).sum(1), (overlap * np.sqrt(lateral2) / safe).sum(1)
    weight = np.clip(1 - np.abs(d[..., 0]), 0, None) * np.clip(1 - np.abs(d[..., 1]), 0, None)
    normal = weight * max(0.0, 1 - h)
    return normal.sum(1), np.zeros(len(a))


def pressed(a, b, law, total):
    """The forces where the summed normal force is `total` (bisection on the planes' distance)."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        h = 0.5 * (lo + hi)
        if forces(a, b, law, h)[0].sum() > total:
            lo = h
        else:
            hi = h
    return forces(a, b, law, 0.5 * (lo + hi))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cells", type=int, default=40, help="cells along a side of the faces (default 40)")
    p.add_argument("--overlap", type=float, default=0.01, help="the mean overlap a site, in spacings (0.01)")
    p.add_argument("--turn", type=float, default=10.0, help="degrees one grid is turned against the other (10)")
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args()
    if a.cells < 12 or a.cells > 120:
        p.error("--cells must be 12 to 120 (five cells of each edge are left out; the pairs are n^4)")
    if not 0 < a.overlap < 0.5:
        p.error("--overlap must be in (0, 0.5) spacings")
    rng = np.random.default_rng(a.seed)
    n = a.cells
    c, s = np.cos(np.radians(a.turn)), np.sin(np.radians(a.turn))
    turned = (face(n, False, rng) - n / 2) @ np.array([[c, -s], [s, c]]).T + n / 2
    cases = (("grids cell on cell", face(n, False, rng), face(n, False, rng)),
             ("random faces", face(n, True, rng), face(n, True, rng)),
             (f"a grid turned {a.turn:g} degrees", face(n, False, rng), turned))
    inner = lambda x: x.reshape(n, n)[5:-5, 5:-5].ravel()  # noqa: E731
    for label, first, second in cases:
        for law in ("sphere", "face"):
            normal, lateral = pressed(first, second, law, a.overlap * n * n)
            normal, lateral = inner(normal), inner(lateral)
            mean = normal.mean()
            print(f"{label:26s} {law:6s}: largest {normal.max() / mean:5.2f} x the mean, "
                  f"{(normal <= 0).mean() * 100:4.1f} % of sites without load, 90th percentile "
                  f"{np.percentile(normal, 90) / mean:4.2f}, along the faces {lateral.sum() / normal.sum():4.2f} "
                  "of the normal force")


if __name__ == "__main__":
    main()
