#!/usr/bin/env python3
"""The two fracture measures of issue 21, from an `mca run` output folder.

1. Crack isotropy (the axis/diagonal damage ratio). From one frame of automata.pvd (the last unless
   --frame/--time): each automaton's initial position is its point minus its `displacement`; those of the
   first object (`object` 0) whose distance from the impact point, measured in the wall's plane, lies in
   [r_in, r_out] are sorted into eight 45-degree sectors centred on the plane's two lattice axes (0, 90,
   180, 270 degrees) and the diagonals (45, 135, 225, 315 degrees). A sector's share is the share of its
   automata with `damage` >= 0.5; the ratio is the mean share of the four axis sectors over that of the
   four diagonal sectors (about 1 for an isotropic material). An empty sector has no share (null) and
   leaves the ratio null, as does a ratio with no damaged diagonal automaton, each with a "reason".

   The radii (unless --r-in/--r-out): 0.25 m and 0.7 m when the impact point lies at least 0.7 m from every
   in-plane edge of the first object (the box of its automata's initial positions +- their `radius`), as
   on the default wall; on a smaller object 0.25 and 0.7 times that distance (the half-width of an object
   struck at its centre), which keeps the annulus off the edges. `mca run` writes the same measure, by the
   same rule, into summary.json's crack_isotropy (src/analysis/crack_isotropy.hpp).

   The plane is the one normal to the projectile's velocity (its largest component: x, y or z), the impact
   point is where the projectile's initial path crosses the plane through the first object's centre, both
   read from the run's scene.toml (first [[projectile]], first [[object]]); --normal and --centre override
   them. The angle is measured from the first in-plane axis towards the second (x then z for a y normal,
   y then z for x, x then y for z). The lattice axes are taken to be the scene's axes (objects not
   rotated).

2. Fragment masses, from fragments.csv, where the run ended or stopped (summary.json's time, printed), whatever
   frame the damage is measured on. With N automata and M their mass: the single automata (count and
   mass share), the mass share of fragments of at least 10 automata and at most N/10 ("between 10
   automata and a tenth of the object"), the largest fragment's share, and a power law n(m) ~ m^-tau
   fitted to the number density of fragment masses in logarithmic bins. Masses are counted in automata,
   m / (M / N) (for one material exactly the automata count): bin k holds [2^k, 2^(k+1)) automata, its
   density is its count over its width 2^k, its abscissa the geometric mean of its smallest and largest
   whole size, sqrt(2^k (2^(k+1) - 1)). The fit is an unweighted least-squares line through log10 n
   against log10 m over the non-empty bins whose sizes lie wholly within [1, N/10] (the largest
   fragments, the cut-off, are left out; --fit-max sets another bound in automata); it reports tau, its
   standard error, R^2, the bins fitted, the empty bins inside the range, and the decades between the
   first and the last fitted point. A fragment's bin is its size rounded to a whole number (halves up),
   at least 1. `mca run` writes the same into summary.json's fragment_mass_distribution
   (src/analysis/fragments.hpp).

Usage:
  /usr/bin/python3 tools/fracture_metrics.py RUN_DIR [--frame K | --time T] [--json OUT.json]
        [--plot OUT.png] [--normal x|y|z] [--centre X Y Z] [--r-in R] [--r-out R] [--threshold 0.5]
        [--fit-max AUTOMATA] [--no-damage] [--no-fragments]

Needs numpy (and matplotlib for --plot). Exit status 2 on a folder or file it cannot read.
"""
import argparse
import csv
import json
import math
import os
import signal
import sys

import numpy as np

AXES = "xyz"


# The run folder's VTK files are read by the Blender add-on's reader (standard library and numpy only, no
# bpy), loaded from its file: the package's __init__ needs Blender.
def _load_reader():
    import importlib.util

    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender", "io_import_mca", "reader.py")
    spec = importlib.util.spec_from_file_location("mca_run_reader", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_reader = _load_reader()
RunError = _reader.RunError


def read_vtu(path):
    """Point data and points of a .vtu frame written by mca: {"Points": (n, 3) array, field name: (n,) or
    (n, k) array, ...}; cell arrays are skipped."""
    points, fields = _reader.read_vtu(str(path))
    return {"Points": points, **fields}


def read_pvd(path):
    """[(time, absolute file path)] of a .pvd collection, in its order."""
    frames = _reader.read_pvd(str(path))
    if not frames:
        raise RunError(f"{path}: no <DataSet> entries")
    return [(t, os.path.join(os.path.dirname(str(path)), f)) for t, f in frames]


def pick_frame(frames, frame=None, time=None):
    if time is not None:
        if not (math.isfinite(time) and time >= 0):
            raise RunError(f"--time {time}: a simulated time is a finite number of seconds, 0 or more")
        k = int(np.argmin([abs(t - time) for t, _ in frames]))
    elif frame is not None:
        k = frame if frame >= 0 else len(frames) + frame
        if not 0 <= k < len(frames):
            raise RunError(f"frame {frame} is not among the {len(frames)} frames")
    else:
        k = len(frames) - 1
    return k, frames[k][0], frames[k][1]


# ---------------------------------------------------------------- scene geometry

def read_scene(run_dir):
    path = os.path.join(run_dir, "scene.toml")
    if not os.path.exists(path):
        return None
    import tomllib

    with open(path, "rb") as f:
        return tomllib.load(f)


def impact_geometry(scene):
    """(normal axis index, 3-vector impact point) from the first projectile and the first object."""
    if not scene or not scene.get("projectile") or not scene.get("object"):
        raise RunError("scene.toml has no [[projectile]] and [[object]] to place the impact; give --normal "
                       "and --centre")
    p = scene["projectile"][0]
    pos = np.asarray(p["position"], float)
    vel = np.asarray(p.get("velocity", [0, 0, 0]), float)
    if not np.any(vel):
        raise RunError("the first projectile does not move; give --normal and --centre")
    axis = int(np.argmax(np.abs(vel)))
    plane = float(scene["object"][0].get("position", [0, 0, 0])[axis])
    t = (plane - pos[axis]) / vel[axis]
    if t < 0:  # as mca's summary.json: no impact to measure around
        raise RunError(f"the first projectile moves away from the plane {AXES[axis]} = {plane:g} m through the first "
                       "object's centre; give --normal and --centre")
    return axis, pos + t * vel


def in_plane_axes(normal):
    return [a for a in range(3) if a != normal]


# ---------------------------------------------------------------- measure 1: damage sectors

R_IN, R_OUT = 0.25, 0.7  # the annulus [m], for objects that hold it
MIN_SECTOR_AUTOMATA = 5  # a sector of fewer gives no share (it would move in steps of more than a fifth)


def annulus_radii(initial, radius, normal, centre):
    """(r_in, r_out, half_width, scaled) by the rule of the module's docstring: half_width is the distance
    from the impact point to the nearest in-plane edge of the box of the automata given (their initial
    positions +- radius)."""
    lo = (initial - radius[:, None]).min(axis=0)
    hi = (initial + radius[:, None]).max(axis=0)
    half = min(min(centre[k] - lo[k], hi[k] - centre[k]) for k in in_plane_axes(normal))
    if not half > 0:
        raise RunError(f"the impact point {list(centre)} lies outside the first object in its plane")
    if half >= R_OUT:
        return R_IN, R_OUT, float(half), False
    return R_IN * half, R_OUT * half, float(half), True


def sector_shares(initial, damage, normal, centre, r_in=R_IN, r_out=R_OUT, threshold=0.5):
    """Shares of damaged automata in eight 45-degree sectors (sector k centred on k * 45 degrees)."""
    a, b = in_plane_axes(normal)
    da = initial[:, a] - centre[a]
    db = initial[:, b] - centre[b]
    r = np.hypot(da, db)
    keep = (r >= r_in) & (r <= r_out)
    ang = np.degrees(np.arctan2(db[keep], da[keep])) % 360.0
    sector = (np.floor((ang + 22.5) / 45.0).astype(int)) % 8
    damaged = damage[keep] >= threshold
    counts = np.bincount(sector, minlength=8)
    hits = np.bincount(sector, weights=damaged.astype(float), minlength=8)
    # None (JSON null), not NaN, for an empty sector and for a ratio that cannot be formed: json.dump would
    # write NaN and Infinity, which are not JSON.
    shares = [float(h / c) if c > 0 else None for h, c in zip(hits, counts)]
    reason = None
    axis_mean = diag_mean = ratio = None
    if any(c == 0 for c in counts):
        empty = [45 * k for k in range(8) if counts[k] == 0]
        reason = (f"no automaton of the annulus {r_in:g}-{r_out:g} m lies in the sector{'s' if len(empty) > 1 else ''} "
                  f"at {', '.join(str(e) for e in empty)} degrees")
    elif any(c < MIN_SECTOR_AUTOMATA for c in counts):
        sparse = ", ".join(f"{45 * k} ({int(c)})" for k, c in enumerate(counts) if c < MIN_SECTOR_AUTOMATA)
        reason = (f"the annulus {r_in:g}-{r_out:g} m holds fewer than {MIN_SECTOR_AUTOMATA} automata in the sectors at "
                  f"{sparse} degrees (the counts in brackets): too few for a share; the measure needs the impact "
                  "point farther from the object's edges, or a finer spacing")
    else:
        axis_mean = float(np.mean(shares[0::2]))
        diag_mean = float(np.mean(shares[1::2]))
        if diag_mean > 0:
            ratio = axis_mean / diag_mean
        else:
            reason = ("no automaton of the diagonal sectors is damaged: the axis/diagonal ratio is unbounded"
                      if axis_mean > 0 else "no automaton of the annulus is damaged: there is no crack to measure")
    res = {
        "plane_axes": [AXES[a], AXES[b]],
        "normal": AXES[normal],
        "centre": [float(c) for c in centre],
        "r_in": r_in, "r_out": r_out, "threshold": threshold,
        "automata_in_annulus": int(keep.sum()),
        "sector_angles_deg": [45 * k for k in range(8)],
        "sector_automata": [int(c) for c in counts],
        "sector_damaged": [int(h) for h in hits],
        "sector_shares": shares,
        "axis_shares": shares[0::2],
        "diagonal_shares": shares[1::2],
        "axis_mean": axis_mean,
        "diagonal_mean": diag_mean,
        "axis_diagonal_ratio": ratio,
    }
    if reason:
        res["reason"] = reason
    return res


def damage_measure(run_dir, frame=None, time=None, normal=None, centre=None, r_in=None, r_out=None, **kw):
    pvd = os.path.join(run_dir, "automata.pvd")
    if not os.path.exists(pvd):
        raise RunError(f"{run_dir}: no automata.pvd (run with VTK output)")
    k, t, path = pick_frame(read_pvd(pvd), frame, time)
    v = read_vtu(path)
    for name in ("displacement", "damage"):
        if name not in v:
            raise RunError(f"{path}: no point field '{name}'")
    initial = v["Points"].astype(float) - v["displacement"].astype(float)
    damage = v["damage"].astype(float)
    # The first object's automata (frames written before the `object` and `radius` fields: all of them,
    # as points).
    radius = v["radius"].astype(float) if "radius" in v else np.zeros(len(initial))
    if "object" in v:
        first = v["object"] == 0
        initial, damage, radius = initial[first], damage[first], radius[first]
    if normal is None or centre is None:
        ax, c = impact_geometry(read_scene(run_dir))
        normal = ax if normal is None else normal
        centre = c if centre is None else centre
    centre = np.asarray(centre, float)
    half, scaled = None, None
    if r_in is None or r_out is None:
        rule_in, rule_out, half, scaled = annulus_radii(initial, radius, normal, centre)
        r_in = rule_in if r_in is None else r_in
        r_out = rule_out if r_out is None else r_out
    if not r_in < r_out:
        raise RunError(f"the annulus {r_in:g}-{r_out:g} m (--r-in, --r-out, or the rule for the other) is empty: "
                       "give an inner radius below the outer one")
    res = sector_shares(initial, damage, normal, centre, r_in=r_in, r_out=r_out, **kw)
    res.update({"frame": k, "time": t, "file": os.path.relpath(path, run_dir), "half_width": half,
                "radii_scaled": scaled})
    return res


# ---------------------------------------------------------------- measure 2: fragment masses

def read_fragments(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise RunError(f"{path}: no fragments")
    for col in ("automata", "mass"):
        if col not in rows[0]:
            raise RunError(f"{path}: no column '{col}'")
    return np.array([int(r["automata"]) for r in rows]), np.array([float(r["mass"]) for r in rows])


def log_bins(sizes, mass=None):
    """Bins [2^k, 2^(k+1)) of sizes in automata: (k, count, density, abscissa, lo, hi, mass share) per bin
    up to the largest. A size goes to the bin of its whole number, halves up ([2^k - 0.5, 2^(k+1) - 0.5)),
    and at least 1: a fragment lighter than half an average automaton is counted in the first bin, and one
    just under a power of two (1023.9999...) in the bin of that power, which the bins reach."""
    whole = np.maximum(np.floor(sizes + 0.5), 1.0).astype(np.int64)
    k_of = np.array([int(w).bit_length() - 1 for w in whole], dtype=np.int64)
    total = float(mass.sum()) if mass is not None else None
    rows = []
    for k in range(int(k_of.max()) + 1):
        lo, hi = 2 ** k, 2 ** (k + 1)
        inside = k_of == k
        count = int(np.count_nonzero(inside))
        row = {"k": k, "lo": lo, "hi": hi - 1, "count": count, "density": count / lo, "m": math.sqrt(lo * (hi - 1))}
        if total:
            row["mass_share"] = float(mass[inside].sum() / total)
        rows.append(row)
    return rows


def power_law_fit(bins, fit_max):
    """Least-squares fit of log10 density against log10 m over non-empty bins with hi <= fit_max."""
    inside = [b for b in bins if b["hi"] <= fit_max]
    used = [b for b in inside if b["count"] > 0]
    res = {"fit_max_automata": fit_max, "bins_in_range": len(inside), "bins_fitted": len(used),
           "empty_bins_in_range": len(inside) - len(used)}
    if len(used) < 2:
        res.update({"tau": None, "tau_stderr": None, "r2": None, "decades": None,
                    "reason": f"{len(used)} non-empty bin{'' if len(used) == 1 else 's'} of at most {fit_max:g} "
                              "automata: a power law needs at least 2"})
        return res
    x = np.log10([b["m"] for b in used])
    y = np.log10([b["density"] for b in used])
    slope, icept = np.polyfit(x, y, 1)
    pred = slope * x + icept
    ss_res = float(np.sum((y - pred) ** 2))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    if len(used) > 2:
        stderr = math.sqrt(ss_res / (len(used) - 2) / float(np.sum((x - x.mean()) ** 2)))
    else:
        stderr = None
    res.update({"tau": float(-slope), "tau_stderr": stderr, "log10_prefactor": float(icept),
                # all fitted densities equal: nothing for the line to explain, R^2 undefined; two bins: a line
                # through both, R^2 = 1 says nothing
                "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 and len(used) > 2 else None,
                "m_first": used[0]["m"], "m_last": used[-1]["m"], "decades": float(x[-1] - x[0])})
    return res


def fragment_measure(run_dir, fit_max=None):
    path = os.path.join(run_dir, "fragments.csv")
    if not os.path.exists(path):
        raise RunError(f"{run_dir}: no fragments.csv")
    automata, mass = read_fragments(path)
    # fragments.csv holds the fragments where the run ended or stopped: summary.json says when.
    when = {"time": None, "status": None}
    try:
        with open(os.path.join(run_dir, "summary.json"), encoding="utf-8") as f:
            summary = json.load(f)
        if isinstance(summary, dict) and isinstance(summary.get("simulated_time"), (int, float)):
            when = {"time": float(summary["simulated_time"]), "status": str(summary.get("status", ""))}
    except (OSError, ValueError):
        pass
    n_total = int(automata.sum())
    m_total = float(mass.sum())
    m_unit = m_total / n_total
    sizes = mass / m_unit
    tenth = n_total / 10.0
    single = automata == 1
    mid = (automata >= 10) & (automata <= tenth)
    small = (automata >= 2) & (automata <= 9)
    big = automata > tenth
    bins = log_bins(sizes, mass)
    fit = power_law_fit(bins, tenth if fit_max is None else fit_max)
    if single.all() and fit["tau"] is not None:
        # rubble alone: the bins above the first hold single automata heavier than the mean (a random
        # lattice's cells differ in volume), and a line through them would fit the cells' spread
        fit = {key: fit[key] for key in ("fit_max_automata", "bins_in_range")}
        fit.update({"bins_fitted": 0, "empty_bins_in_range": fit["bins_in_range"], "tau": None, "tau_stderr": None,
                    "r2": None, "decades": None,
                    "reason": "every fragment is a single automaton: the spread of their masses is the lattice "
                              "cells', not a distribution of fragments"})
    return {
        "fragments": int(len(automata)), "automata": n_total, "mass": m_total, "automaton_mass": m_unit,
        "single_count": int(single.sum()), "single_mass_share": float(mass[single].sum() / m_total),
        "small_2_9_count": int(small.sum()), "small_2_9_mass_share": float(mass[small].sum() / m_total),
        "mid_count": int(mid.sum()), "mid_mass_share": float(mass[mid].sum() / m_total),
        "mid_range_automata": [10, tenth],
        "above_tenth_count": int(big.sum()), "above_tenth_mass_share": float(mass[big].sum() / m_total),
        "above_tenth_sizes": sorted((int(a) for a in automata[big]), reverse=True),
        # the heaviest fragment (the first of equal ones, as fragments.csv lists them)
        "largest_automata": int(automata[int(np.argmax(mass))]), "largest_mass_share": float(mass.max() / m_total),
        "bins": bins, "fit": fit, "time": when["time"], "status": when["status"],
    }


def summary_form(frag):
    """fragment_measure's result in the form of summary.json's fragment_mass_distribution (what `mca run`
    writes; README, "Outputs"), for the plot that both draw."""
    unit = frag["automaton_mass"]
    fit = frag["fit"]
    fitted = fit["tau"] is not None
    power_law = {
        "fit_max_automata": fit["fit_max_automata"], "bins_in_range": fit["bins_in_range"],
        "bins_fitted": fit["bins_fitted"], "empty_bins_in_range": fit["empty_bins_in_range"],
        "tau": fit["tau"], "tau_stderr": fit["tau_stderr"], "r2": fit["r2"],
        "log10_prefactor": fit.get("log10_prefactor"),
        "range_automata": [fit["m_first"], fit["m_last"]] if fitted else None,
        "range_kg": [fit["m_first"] * unit, fit["m_last"] * unit] if fitted else None,
        "decades": fit["decades"],
    }
    if not fitted:
        power_law["reason"] = fit["reason"]
    return {
        "automata": frag["automata"], "fragments": frag["fragments"], "mass": frag["mass"], "automaton_mass": unit,
        "bins": [{"automata_min": b["lo"], "automata_max": b["hi"], "count": b["count"], "number_density": b["density"],
                  "abscissa_automata": b["m"], "abscissa_kg": b["m"] * unit, "mass_share": b["mass_share"]}
                 for b in frag["bins"]],
        "singles": {"count": frag["single_count"], "mass_share": frag["single_mass_share"]},
        "fragments_2_to_9": {"count": frag["small_2_9_count"], "mass_share": frag["small_2_9_mass_share"]},
        "fragments_10_to_tenth": {"count": frag["mid_count"], "mass_share": frag["mid_mass_share"],
                                  "automata_min": 10, "automata_max": frag["mid_range_automata"][1]},
        "fragments_above_tenth": {"count": frag["above_tenth_count"], "mass_share": frag["above_tenth_mass_share"]},
        "largest": {"automata": frag["largest_automata"], "mass_share": frag["largest_mass_share"]},
        "power_law": power_law,
    }


def plot_spectrum(frag, path, title=""):
    """n(m) with the fit and the published band, drawn as `mca run --render` draws render/fragment_masses.png
    (tools/plot_run.py)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    here = os.path.dirname(os.path.abspath(__file__))  # plot_run.py lies beside this file
    if here not in sys.path:
        sys.path.insert(0, here)
    import plot_run

    plot_run.plot_mass_distribution(plt, summary_form(frag), path, title or "Fragment mass spectrum",
                                    "fracture_metrics.py")


# ---------------------------------------------------------------- report

def _fmt_share(x):
    return "-" if x is None else f"{x:.3f}"


def report(res):
    lines = []
    d = res.get("damage")
    if d:
        lines.append(f"damage sectors: frame {d['frame']} (t = {d['time'] * 1e3:.1f} ms), plane "
                     f"{d['plane_axes'][0]}{d['plane_axes'][1]}, centre ({', '.join(f'{c:.3f}' for c in d['centre'])}), "
                     f"annulus {d['r_in']}-{d['r_out']} m: {d['automata_in_annulus']} automata, damage >= {d['threshold']}")
        lines.append("  sector (deg):  " + "  ".join(f"{a:>5d}" for a in d["sector_angles_deg"]))
        lines.append("  automata:      " + "  ".join(f"{c:>5d}" for c in d["sector_automata"]))
        lines.append("  damaged share: " + "  ".join(f"{_fmt_share(s):>5}" for s in d["sector_shares"]))
        lines.append(f"  axes {', '.join(_fmt_share(s) for s in d['axis_shares'])} (mean {_fmt_share(d['axis_mean'])}); "
                     f"diagonals {', '.join(_fmt_share(s) for s in d['diagonal_shares'])} "
                     f"(mean {_fmt_share(d['diagonal_mean'])})")
        if d["axis_diagonal_ratio"] is None:
            lines.append(f"  axis/diagonal ratio: none ({d['reason']})")
        else:
            lines.append(f"  axis/diagonal ratio: {d['axis_diagonal_ratio']:.2f}")
    f = res.get("fragments")
    if f:
        when = "at the run's end" if f.get("status") in (None, "finished") else f"where the run stopped: {f['status']}"
        if f.get("time") is not None:
            when += f", t = {f['time'] * 1e3:.1f} ms"
        # (the damage above may be of an earlier frame: say so, the two are not of one moment)
        if d and f.get("time") is not None and abs(d["time"] - f["time"]) > 1e-9 * max(1.0, f["time"]):
            when += f"; not frame {d['frame']}"
        lines.append(f"fragments ({when}; fragments.csv): {f['fragments']} of {f['automata']} automata "
                     f"({f['mass']:.1f} kg)")
        lines.append(f"  single automata: {f['single_count']} ({100 * f['single_mass_share']:.1f} % of the mass); "
                     f"2-9 automata: {f['small_2_9_count']} ({100 * f['small_2_9_mass_share']:.1f} %)")
        lines.append(f"  10 to {f['mid_range_automata'][1]:g} automata: {f['mid_count']} "
                     f"({100 * f['mid_mass_share']:.1f} % of the mass); above: {f['above_tenth_count']} "
                     f"{f['above_tenth_sizes'][:6]}")
        lines.append(f"  largest: {f['largest_automata']} automata ({100 * f['largest_mass_share']:.1f} % of the mass)")
        lines.append("  bins (automata: fragments): " +
                     ", ".join(f"{b['lo']}-{b['hi']}: {b['count']}" for b in f["bins"]))
        fit = f["fit"]
        if fit["tau"] is None:
            lines.append(f"  power law: no fit ({fit['reason']})")
        else:
            se = f" +- {fit['tau_stderr']:.2f}" if fit["tau_stderr"] is not None else ""
            lines.append(f"  power law n(m) ~ m^-tau up to {fit['fit_max_automata']:g} automata: tau = {fit['tau']:.2f}{se}, "
                         f"R^2 = {_fmt_share(fit['r2'])}, {fit['bins_fitted']} bins ({fit['empty_bins_in_range']} empty in range), "
                         f"{fit['decades']:.2f} decades (m = {fit['m_first']:.1f} to {fit['m_last']:.1f} automata)")
    return "\n".join(lines)


def main(argv=None):
    if hasattr(signal, "SIGPIPE"):  # `| head` ends the output quietly
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--frame", type=int, help="frame index in automata.pvd (negative from the end; default last)")
    g.add_argument("--time", type=float, help="the frame nearest this time [s]")
    ap.add_argument("--json", help="write the measures to this JSON file")
    ap.add_argument("--plot", help="write the fragment mass spectrum to this PNG")
    ap.add_argument("--normal", choices=list(AXES), help="the wall plane's normal (default: from the projectile)")
    ap.add_argument("--centre", type=float, nargs=3, metavar=("X", "Y", "Z"),
                    help="impact point (default: the projectile's path through the object's centre plane)")
    ap.add_argument("--r-in", type=float, help="inner radius of the annulus [m] (default: by the rule above)")
    ap.add_argument("--r-out", type=float, help="outer radius of the annulus [m] (default: by the rule above)")
    ap.add_argument("--threshold", type=float, default=0.5)
    ap.add_argument("--fit-max", type=float, help="largest fragment size fitted, in automata (default N/10)")
    ap.add_argument("--no-damage", action="store_true")
    ap.add_argument("--no-fragments", action="store_true")
    a = ap.parse_args(argv)
    for opt, v in (("--r-in", a.r_in), ("--r-out", a.r_out), ("--threshold", a.threshold), ("--fit-max", a.fit_max)):
        if v is not None and not (math.isfinite(v) and v >= 0):
            ap.error(f"{opt} {v:g}: give a finite number >= 0")
    if a.r_in is not None and a.r_out is not None and not a.r_in < a.r_out:
        ap.error(f"--r-in {a.r_in:g} --r-out {a.r_out:g}: the inner radius must be below the outer one")
    res = {"run": os.path.abspath(a.run_dir)}
    try:
        if not os.path.isdir(a.run_dir):
            raise RunError(f"{a.run_dir} is not a folder")
        for opt, out in (("--json", a.json), ("--plot", a.plot)):
            if out and not os.path.isdir(os.path.dirname(os.path.abspath(out))):
                raise RunError(f"{opt} {out}: the folder {os.path.dirname(os.path.abspath(out))} does not exist")
        if not a.no_damage:
            res["damage"] = damage_measure(a.run_dir, a.frame, a.time,
                                           None if a.normal is None else AXES.index(a.normal), a.centre,
                                           r_in=a.r_in, r_out=a.r_out, threshold=a.threshold)
        if not a.no_fragments:
            res["fragments"] = fragment_measure(a.run_dir, a.fit_max)
            if a.plot:
                plot_spectrum(res["fragments"], a.plot, os.path.basename(os.path.abspath(a.run_dir)))
    except (RunError, OSError, KeyError, ValueError) as e:
        print(f"fracture_metrics.py: {e}", file=sys.stderr)
        return 2
    print(report(res))
    if a.json:
        try:
            with open(a.json, "w") as f:
                json.dump(res, f, indent=1, allow_nan=False)  # NaN or Infinity would not be JSON
        except OSError as e:
            print(f"fracture_metrics.py: could not write {a.json}: {e.strerror or e}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
