#!/usr/bin/env python3
"""An independent continuum reference for a box dropped flat on the ground: linear elasticity by finite
elements, nothing of mca's in it, to compare the lattice's drops with (docs/model-notes.md, "Drops").

A cube of side `size` falls at `speed` with its bottom face touching a rigid, flat, frictionless floor at
t = 0. Explicit dynamics: 8-node hexahedra of side size / cells with 2x2x2 Gauss points (every element
alike, so one 24 x 24 stiffness serves all), lumped masses, central differences at `courant` times the
pressure wave's transit of an element (less where the viscosity needs it). The floor holds each bottom node
up and never pulls it (a node that would pass z = 0 stops there; one its element pulls up leaves). The
material is elastic, or with --damping-time a Kelvin-Voigt solid as mca's materials are: the stress
D strain + damping_time Dv d strain / dt, with Dv = D (isotropic), or, with --viscosity axial, only on the
normal strain rates along the axes, Dv = diag(M, M, M, 0, 0, 0) with M = lambda + 2 mu: what the cubic
lattice's dashpots are, on its links' stretching along the axes (the random lattice's links point every
way, nearer the isotropic kind).

What it prints, every `every` seconds: the mean vertical strain between two horizontal bands of the
cube (the nodes within 0.07 of the size of the heights 11/30 and 19/30 of it: z = 0.11 and 0.19 m of a
0.3 m cube, its middle), the largest vertical stress of an element (at its centre) with that element's
height and distance from the axis, and the mean vertical velocity. Read the bands: the elements' stresses
ring after the floor's sudden stop (at Poisson's ratio 0, where the exact answer has no tension, they show
up to 6 MPa, and refining does not remove it).

Concrete (30 GPa, 2400 kg/m^3), 0.3 m, 1 m/s (a 5 cm drop), the bands' first tension after the compression:
- elastic, Poisson's ratio 0: a bundle of 1-D bars, which leaves the floor at its speed with no stress left
  (3.3e-5, 1.2e-5 and 1.05e-5 at 12, 16 and 24 cells: the elements' ringing, falling as they are refined;
  it leaves at 0.95 m/s);
- elastic, 0.2: the lateral motion of the compressed cube turns into a vibration of the whole body after it
  leaves, which stretches its middle by 1.0 to 1.1e-4 at 0.235 to 0.246 ms (12 to 30 cells); it leaves at
  0.87 m/s;
- with mca's default viscosity (--damping-time 5e-6): 9.0 to 9.2e-5 at 0.21 ms at ratio 0 (the viscosity
  smears the unloading wave over some 15 cm, and the cube leaves the floor with its parts moving unevenly,
  at 0.73 m/s), 1.02 to 1.05e-4 at 0.215 ms at 0.2 (0.69 m/s); 12, 16 and 24 cells. Axial: the same at
  0, 9.5e-5 at 0.2 (0.67 m/s). Without the viscosity a 1-D bar leaves clean; with 1e-6, 2.5e-6, 5e-6, 1e-5
  and 2e-5 s it is stretched by 8.2, 9.1, 9.1, 7.6 and 4.0e-5: a property of the Kelvin-Voigt solid, which
  real concrete, whose damping hardly depends on the frequency, need not share.
These hold for a rigid floor flat to about 0.3 mrad across the face; a tilt of 1 mrad, a rough or a softer
floor lower them several times (docs/model-notes.md).

  tools/continuum_drop.py                                   # elastic concrete, 16 cells
  tools/continuum_drop.py --damping-time 5e-6               # mca's material, isotropic viscosity
  tools/continuum_drop.py --damping-time 5e-6 --viscosity axial   # as on the cubic lattice
  tools/continuum_drop.py --poisson 0 --cells 24            # the 1-D case: no tension after the rebound
"""
import argparse
import sys

import numpy as np

# The two bands whose distance gives the middle's strain: their heights as shares of the size, and their
# half-width (the lattice's comparison in python/tests/test_continuum_drop.py takes the same bands).
BANDS = (11.0 / 30.0, 19.0 / 30.0)
BAND_HALF_WIDTH = 0.07


def _element_matrices(h, youngs, poisson, viscosity):
    """The elasticity matrix D (Voigt: xx yy zz yz xz xy, engineering shears), the viscous one (D itself, or
    the axial diag(M, M, M, 0, 0, 0)), an element's stiffness and viscous matrix (24 x 24, node-major x y z)
    and its strain-displacement matrix at the centre."""
    lam = youngs * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = youngs / (2 * (1 + poisson))
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[[0, 1, 2], [0, 1, 2]] += 2 * mu
    D[[3, 4, 5], [3, 4, 5]] = mu
    Dv = D if viscosity == "isotropic" else np.diag([lam + 2 * mu] * 3 + [0.0] * 3)
    corners = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=float)

    def strain_matrix(xi):
        dN = np.zeros((8, 3))
        for a, c in enumerate(corners):
            f = [xi[d] if c[d] else 1 - xi[d] for d in range(3)]
            s = [1 if c[d] else -1 for d in range(3)]
            dN[a] = [s[0] * f[1] * f[2], f[0] * s[1] * f[2], f[0] * f[1] * s[2]]
        dN /= h
        B = np.zeros((6, 24))
        for a in range(8):
            x, y, z = 3 * a, 3 * a + 1, 3 * a + 2
            B[0, x], B[1, y], B[2, z] = dN[a]
            B[3, y], B[3, z] = dN[a, 2], dN[a, 1]
            B[4, x], B[4, z] = dN[a, 2], dN[a, 0]
            B[5, x], B[5, y] = dN[a, 1], dN[a, 0]
        return B

    g = (0.5 - 0.5 / np.sqrt(3), 0.5 + 0.5 / np.sqrt(3))
    K = np.zeros((24, 24))
    Kv = np.zeros((24, 24))
    for a in g:
        for b in g:
            for c in g:
                B = strain_matrix((a, b, c))
                K += B.T @ D @ B * (h ** 3 / 8)
                Kv += B.T @ Dv @ B * (h ** 3 / 8)
    return D, Dv, K, Kv, strain_matrix((0.5, 0.5, 0.5)), corners, lam + 2 * mu


def drop(cells=16, poisson=0.2, youngs=30e9, density=2400.0, size=0.3, speed=1.0, duration=0.5e-3,
         every=2.5e-6, courant=0.3, damping_time=0.0, viscosity="isotropic"):
    """Runs the drop; returns a dict of arrays over the samples: t [s], strain (the bands', tension
    positive), sigma_zz (the largest vertical stress of an element [Pa]), at_z, at_r (where [m]) and
    velocity (the mean vertical velocity [m/s]). damping_time: a Kelvin-Voigt viscosity, stress
    D strain + damping_time Dv d strain / dt, as mca's materials' damping_time; viscosity: "isotropic"
    (Dv = D) or "axial" (Dv = diag(M, M, M, 0, 0, 0), M = lambda + 2 mu: on the normal strain rates along
    the axes alone, as the cubic lattice's dashpots, which act on its links' stretching)."""
    if cells < 2 or not 0 < size or not 0 < youngs or not 0 < density or not -1 < poisson < 0.5:
        raise ValueError("cells >= 2, size, youngs and density > 0, -1 < poisson < 0.5")
    if not 0 <= damping_time < 1:
        raise ValueError("0 <= damping_time < 1 s")
    if viscosity not in ("isotropic", "axial"):
        raise ValueError("viscosity: isotropic or axial")
    h = size / cells
    D, Dv, K, Kv, B_centre, corners, p_modulus = _element_matrices(h, youngs, poisson, viscosity)
    n1 = cells + 1
    k, j, i = np.meshgrid(np.arange(n1), np.arange(n1), np.arange(n1), indexing="ij")
    x0 = np.stack([i.ravel() * h - size / 2, j.ravel() * h - size / 2, k.ravel() * h], axis=1)
    ek, ej, ei = np.meshgrid(np.arange(cells), np.arange(cells), np.arange(cells), indexing="ij")
    base = np.stack([ei.ravel(), ej.ravel(), ek.ravel()], axis=1)
    nodes = base[:, None, :] + corners[None, :, :].astype(int)
    elements = (nodes[..., 2] * n1 + nodes[..., 1]) * n1 + nodes[..., 0]
    dof = (elements[:, :, None] * 3 + np.arange(3)).reshape(len(elements), 24)
    mass = np.zeros(len(x0))
    np.add.at(mass, elements.ravel(), density * h ** 3 / 8)
    centres = x0[elements].mean(axis=1)
    u = np.zeros_like(x0)
    v = np.zeros_like(x0)
    v[:, 2] = -speed
    c = np.sqrt(p_modulus / density)
    dt = courant * h / c
    if damping_time > 0:
        # Central differences with the damping on the half-step velocity are stable while omega dt stays
        # under 2 (sqrt(1 + zeta^2) - zeta), zeta = damping_time omega / 2, for the highest mode (omega at
        # most 2 sqrt(3) c / h for these elements with lumped masses); 0.9 of that.
        omega = 2 * np.sqrt(3) * c / h
        zeta = damping_time * omega / 2
        dt = min(dt, 0.9 * 2 / omega * (np.sqrt(1 + zeta * zeta) - zeta))
    bottom = k.ravel() == 0
    lo = np.abs(x0[:, 2] - BANDS[0] * size) <= BAND_HALF_WIDTH * size + 1e-12 * size
    hi = np.abs(x0[:, 2] - BANDS[1] * size) <= BAND_HALF_WIDTH * size + 1e-12 * size
    gap0 = x0[hi, 2].mean() - x0[lo, 2].mean()
    out = {key: [] for key in ("t", "strain", "sigma_zz", "at_z", "at_r", "velocity")}
    steps = int(np.ceil(duration / dt))
    sample = max(1, int(round(every / dt)))
    for step in range(1, steps + 1):
        ue = u.reshape(-1)[dof]
        fe = ue @ K.T
        if damping_time > 0:
            ve = v.reshape(-1)[dof]
            fe = fe + damping_time * (ve @ Kv.T)
        force = np.zeros(u.size)
        np.add.at(force, dof.ravel(), -fe.ravel())
        v += dt * force.reshape(-1, 3) / mass[:, None]
        z = x0[bottom, 2] + u[bottom, 2]
        vz = v[bottom, 2]
        v[bottom, 2] = np.maximum(vz, -z / dt)  # the floor: stop at z = 0, never pulled down
        u += dt * v
        if step % sample == 0 or step == steps:
            szz = ((ue @ B_centre.T) @ D)[:, 2]
            if damping_time > 0:
                szz = szz + damping_time * ((ve @ B_centre.T) @ Dv)[:, 2]  # (the viscous stress too)
            e = int(szz.argmax())
            zz = x0[:, 2] + u[:, 2]
            out["t"].append(step * dt)
            out["strain"].append(((zz[hi].mean() - zz[lo].mean()) - gap0) / gap0)
            out["sigma_zz"].append(szz[e])
            out["at_z"].append(centres[e, 2])
            out["at_r"].append(np.hypot(centres[e, 0], centres[e, 1]))
            out["velocity"].append((v[:, 2] * mass).sum() / mass.sum())
    return {key: np.array(val) for key, val in out.items()}


def first_tension_peak(t, strain):
    """The time and value of the bands' first tensile peak after the compression: the largest strain
    between the first positive sample after the most compressed one and the next time the strain turns
    negative. None where the strain never turns positive after its compression."""
    t, strain = np.asarray(t), np.asarray(strain)
    start = int(strain.argmin())
    after = np.nonzero(strain[start:] > 0)[0]
    if not len(after):
        return None
    a = start + int(after[0])
    end = np.nonzero(strain[a:] < 0)[0]
    b = a + int(end[0]) if len(end) else len(strain)
    peak = a + int(strain[a:b].argmax())
    return float(t[peak]), float(strain[peak])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cells", type=int, default=16, help="elements along an edge (default 16)")
    p.add_argument("--poisson", type=float, default=0.2, help="Poisson's ratio (default 0.2, concrete)")
    p.add_argument("--youngs", type=float, default=30e9, help="Young's modulus [Pa] (default 30e9)")
    p.add_argument("--density", type=float, default=2400.0, help="[kg/m^3] (default 2400)")
    p.add_argument("--size", type=float, default=0.3, help="the cube's side [m] (default 0.3)")
    p.add_argument("--speed", type=float, default=1.0, help="at touch-down [m/s] (default 1: a 5 cm drop)")
    p.add_argument("--duration", type=float, default=0.5e-3, help="[s] after touch-down (default 5e-4)")
    p.add_argument("--every", type=float, default=2.5e-6, help="sample interval [s] (default 2.5e-6)")
    p.add_argument("--damping-time", type=float, default=0.0,
                   help="Kelvin-Voigt viscosity [s], as a material's damping_time in mca (default 0: elastic)")
    p.add_argument("--viscosity", choices=("isotropic", "axial"), default="isotropic",
                   help="isotropic (the viscous stress proportional to the elastic one), or axial (on the normal "
                        "strain rates along the axes alone, as the cubic lattice's link dashpots)")
    a = p.parse_args(argv)
    try:
        r = drop(a.cells, a.poisson, a.youngs, a.density, a.size, a.speed, a.duration, a.every,
                 damping_time=a.damping_time, viscosity=a.viscosity)
    except ValueError as e:
        sys.exit(f"continuum_drop: {e}")
    print(f"# {a.size} m cube, E {a.youngs:g} Pa, nu {a.poisson}, rho {a.density} kg/m^3, damping time "
          f"{a.damping_time:g} s ({a.viscosity}), {a.speed} m/s, {a.cells} cells a side")
    print("#   t [ms]  band strain  max sigma_zz [MPa]  at z [m]  at r [m]  mean v_z [m/s]")
    for row in zip(r["t"], r["strain"], r["sigma_zz"], r["at_z"], r["at_r"], r["velocity"]):
        print(f"{row[0] * 1e3:9.4f}  {row[1]:+.3e}  {row[2] / 1e6:18.2f}  {row[3]:8.3f}  {row[4]:8.3f}  "
              f"{row[5]:+14.3f}")
    peak = first_tension_peak(r["t"], r["strain"])
    if peak:
        print(f"# the middle's first tension: strain {peak[1]:.3e} at {peak[0] * 1e3:.3f} ms; "
              f"mean vertical velocity at the end {r['velocity'][-1]:+.3f} m/s")
    else:
        print(f"# the middle is not stretched after the compression; mean vertical velocity at the end "
              f"{r['velocity'][-1]:+.3f} m/s")


if __name__ == "__main__":
    main()
