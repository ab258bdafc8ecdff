#!/usr/bin/env python3
"""How the automata that end as single-automaton fragments were cut loose (issue 21's diagnosis).

Reads an `mca run` output folder that has VTK frames and a checkpoint (run with --checkpoint-every N so
that the last frame writes one):

- the break records (step, link slot, criterion) from the newest checkpoint in checkpoints/: every link
  that broke in the run, with the step it broke in (src/core/state.hpp BreakRecord; the checkpoint format
  is src/io/checkpoint.cpp, formats 6 to 8: the checksum is checked, the records read back from the file's end);
- frame 0 of automata.pvd for the initial positions, strength classes and objects; link slot l = axis * n
  + a joins automaton a to its lattice neighbour along +axis (core/model.hpp), found here from the
  positions (each object's own lattice, spacing from summary.json; objects must not be rotated);
- every frame's `fragment` field for the singles over time, the chosen frame's (default last) for the
  singles studied.

It prints, for the singles against all automata: their links (how many each had), the spread in steps
between the first and the last break of each single's links and how many broke in its last step, the
criteria, the strength classes (the single's own against its neighbours': a link takes the weaker end's
strength), their position across the wall (along the impact normal) and their distance from the impact
point, and when their last link broke; for all breaks, how many fell in the same step as another break
of a link of the same automaton. --json writes it all.

Usage: /usr/bin/python3 tools/break_history.py RUN_DIR [--frame K] [--json OUT.json]
"""
import argparse
import glob
import json
import os
import signal
import struct
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fracture_metrics as fm  # noqa: E402

# Format 7 adds the links' damage before the records, format 8 the contact pairs' way of touching: the tail
# is the same. (tests/python_tools/test_break_history.py reads a checkpoint the built mca writes.)
MAGICS = (b"MCACKPT6", b"MCACKPT7", b"MCACKPT8")
RECORD = np.dtype([("step", "<i8"), ("link", "<u4"), ("criterion", "u1")])  # 13 bytes, no padding
# The checksum is FNV-1a as src/core/fnv.hpp computes it: its offset basis is 1469598103934665603
# (0x14650fb0739d0383), not the published FNV-1a 64-bit basis 14695981039346656037.
FNV_BASIS, FNV_PRIME = 1469598103934665603, 1099511628211


def fnv1a(data):
    h = FNV_BASIS
    for b in data:
        h = ((h ^ b) * FNV_PRIME) & 0xFFFFFFFFFFFFFFFF
    return h
def read_breaks(path, expected=None, verify=True):
    """Break records of a format-6 to -8 checkpoint, read from its end: ... breaks (u64 count, 13-byte records),
    broken_by (2 x i64), initial_energy (f64), grip_work (u64 count, f64 each), grip_force (u64 count,
    3 x f32 each), checksum (u64), magic. Tries grip counts 0..64 and keeps the one whose counts agree
    (the record count with broken_by's sum, the displacement records with broken_by[0]). With verify, the
    checksum over every byte before it is checked first (pure Python: about 0.4 s a megabyte)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] in MAGICS and data[-8:] != data[:8]:
        raise fm.RunError(f"{path}: cut short or damaged (no end marker {data[:8].decode()} at its end)")
    if data[:8] not in MAGICS:
        raise fm.RunError(f"{path}: not a format-6 to -8 mca checkpoint (magic {data[:8]!r}; this tool reads {', '.join(m.decode() for m in MAGICS)})")
    if verify and fnv1a(data[:-16]) != struct.unpack_from("<Q", data, len(data) - 16)[0]:
        raise fm.RunError(f"{path}: its checksum does not match its contents")
    end = len(data) - 16  # before checksum and magic
    for grips in range(65):
        gf = end - (8 + 12 * grips)
        if gf < 0 or struct.unpack_from("<Q", data, gf)[0] != grips:
            continue
        gw = gf - (8 + 8 * grips)
        if gw < 0 or struct.unpack_from("<Q", data, gw)[0] != grips:
            continue
        bb = gw - 8 - 16
        by = struct.unpack_from("<qq", data, bb)
        n = by[0] + by[1]
        if expected is not None and n != expected:
            continue
        cnt_at = bb - 13 * n - 8
        if cnt_at < 0 or struct.unpack_from("<Q", data, cnt_at)[0] != n:
            continue
        rec = np.frombuffer(data, RECORD, n, cnt_at + 8)
        if np.count_nonzero(rec["criterion"] == 0) != by[0]:
            continue
        return rec, {"displacement": by[0], "stress": by[1]}
    raise fm.RunError(f"{path}: could not find the break records at the end of the checkpoint")


def lattice_neighbours(pos, obj, spacing):
    """(3, n) array: the automaton next along +axis in the same object, -1 if none."""
    n = len(pos)
    up = np.full((3, n), -1, dtype=np.int64)
    for o in np.unique(obj):
        sel = np.flatnonzero(obj == o)
        p = pos[sel]
        idx = np.rint((p - p.min(axis=0)) / spacing).astype(np.int64)
        if np.abs(idx * spacing + p.min(axis=0) - p).max() > 0.01 * spacing:
            raise fm.RunError(f"object {o}: automata are not on an axis-aligned lattice of spacing {spacing}: "
                              "this tool reads the cubic lattice's links (run the scene with lattice = \"cubic\" "
                              "in [solver]; the random lattice is the default)")
        dims = idx.max(axis=0) + 2
        key = (idx[:, 0] * dims[1] + idx[:, 1]) * dims[2] + idx[:, 2]
        lookup = dict(zip(key.tolist(), sel.tolist()))
        for axis in range(3):
            step = np.zeros(3, dtype=np.int64)
            step[axis] = 1
            k2 = ((idx[:, 0] + step[0]) * dims[1] + idx[:, 1] + step[1]) * dims[2] + idx[:, 2] + step[2]
            up[axis, sel] = [lookup.get(k, -1) for k in k2.tolist()]
    return up


def share_table(values, subset, categories):
    """{category: [count in subset, share of subset, count among all, share among all]}."""
    out = {}
    for c in categories:
        a = int(np.count_nonzero(values[subset] == c))
        b = int(np.count_nonzero(values == c))
        out[str(c)] = [a, a / max(int(subset.sum()), 1), b, b / max(len(values), 1)]
    return out


def analyse(run_dir, frame=None):
    summary = json.load(open(os.path.join(run_dir, "summary.json")))
    spacing = float(summary["spacing"])
    dt = float(summary["time_step"])
    cps = sorted(glob.glob(os.path.join(run_dir, "checkpoints", "frame_*.mcack")))
    if not cps:
        raise fm.RunError(f"{run_dir}: no checkpoints (run with --checkpoint-every N)")
    frames = fm.read_pvd(os.path.join(run_dir, "automata.pvd"))
    k, t_frame, path = fm.pick_frame(frames, frame)
    cp_frame = int(os.path.basename(cps[-1])[6:-6])
    if cp_frame != k:
        raise fm.RunError(f"the newest checkpoint is of frame {cp_frame}, the frame studied is {k}: pass --frame {cp_frame}")
    rec, by = read_breaks(cps[-1], expected=None)
    f0 = fm.read_vtu(frames[0][1])
    fk = fm.read_vtu(path)
    pos = f0["Points"].astype(float)
    n = len(pos)
    cls = f0["strength_class"].astype(int)
    obj = f0["object"].astype(int)
    up = lattice_neighbours(pos, obj, spacing)
    # links: slot -> (i, j)
    slot_i = rec["link"] % n
    slot_ax = rec["link"] // n
    if np.any(slot_ax > 2):
        raise fm.RunError("explicit links (surface mode) are not studied here")
    slot_j = up[slot_ax, slot_i]
    if np.any(slot_j < 0):
        raise fm.RunError(f"{int(np.sum(slot_j < 0))} break records name a slot without a lattice link")
    # every link of every automaton (initial)
    links_i, links_j, links_slot = [], [], []
    for axis in range(3):
        a = np.flatnonzero(up[axis] >= 0)
        links_i.append(a)
        links_j.append(up[axis, a])
        links_slot.append(axis * n + a)
    links_i, links_j, links_slot = map(np.concatenate, (links_i, links_j, links_slot))
    degree = np.bincount(links_i, minlength=n) + np.bincount(links_j, minlength=n)
    broken_step = np.full(3 * n, -1, dtype=np.int64)
    broken_crit = np.full(3 * n, -1, dtype=np.int64)
    broken_step[rec["link"]] = rec["step"]
    broken_crit[rec["link"]] = rec["criterion"]

    frag = fk["fragment"].astype(int)
    sizes = np.bincount(frag)
    single = sizes[frag] == 1
    # per automaton: its links' break steps
    first = np.full(n, np.iinfo(np.int64).max)
    last = np.full(n, -1, dtype=np.int64)
    unbroken = np.zeros(n, dtype=np.int64)
    for a_end in (links_i, links_j):
        s = broken_step[links_slot]
        np.minimum.at(first, a_end, np.where(s >= 0, s, np.iinfo(np.int64).max))
        np.maximum.at(last, a_end, s)
        np.add.at(unbroken, a_end, (s < 0).astype(np.int64))
    if np.any(unbroken[single] > 0):
        raise fm.RunError(f"{int(np.sum(unbroken[single] > 0))} singles keep an intact link (frame and checkpoint disagree)")
    in_last = np.zeros(n, dtype=np.int64)
    for a_end in (links_i, links_j):
        s = broken_step[links_slot]
        np.add.at(in_last, a_end, (s >= 0) & (s == last[a_end]))
    crit_single = {0: 0, 1: 0}
    weaker = {"single weaker": 0, "equal": 0, "single stronger": 0}
    for a_end, b_end in ((links_i, links_j), (links_j, links_i)):
        m = single[a_end]
        for c in (0, 1):
            crit_single[c] += int(np.count_nonzero(broken_crit[links_slot[m]] == c))
        ca, cb = cls[a_end[m]], cls[b_end[m]]
        weaker["single weaker"] += int(np.count_nonzero(ca < cb))
        weaker["equal"] += int(np.count_nonzero(ca == cb))
        weaker["single stronger"] += int(np.count_nonzero(ca > cb))
    first_step = int(rec["step"].min()) if len(rec) else 0
    spread = (last - first)[single]
    # position across the wall and from the impact
    scene = fm.read_scene(run_dir)
    origin = "the impact"
    try:
        normal, centre = fm.impact_geometry(scene)
    except fm.RunError:  # no projectile (a pulled bar): distances from the object's centre, normal y
        normal, centre = 1, pos.mean(axis=0)
        origin = "the automata's centre (no projectile: no impact)"
    across = np.rint((pos[:, normal] - pos[:, normal].min()) / spacing).astype(int)
    pa, pb = fm.in_plane_axes(normal)
    radius = np.hypot(pos[:, pa] - centre[pa], pos[:, pb] - centre[pb])
    rbins = [0, 0.25, 0.5, 0.7, 1.0, 10.0]
    rcat = np.digitize(radius, rbins) - 1
    # when singles appear: every frame's fragment field
    over_time = []
    for t, fpath in frames:
        fr = fm.read_vtu(fpath)["fragment"].astype(int)
        over_time.append([t, int(np.count_nonzero(np.bincount(fr)[fr] == 1))])
    t_last = (last[single] - first_step) * dt
    tbins = [0, 1e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 1.0]
    # co-breaking: breaks that share an automaton with another break of the same step
    key_i = np.stack([rec["step"], slot_i]).T
    key_j = np.stack([rec["step"], slot_j]).T
    both = np.concatenate([key_i, key_j])
    uniq, counts = np.unique(both, axis=0, return_counts=True)
    cnt = {tuple(u): c for u, c in zip(uniq.tolist(), counts.tolist())}
    shared = np.array([cnt[(s, i)] > 1 or cnt[(s, j)] > 1 for s, i, j in zip(rec["step"].tolist(), slot_i.tolist(), slot_j.tolist())])
    per_step = np.bincount(rec["step"] - first_step) if len(rec) else np.zeros(1, int)
    # broken links by lattice axis (named by the scene's axes), over time after the first break
    broken_per_automaton = np.bincount(slot_i, minlength=n) + np.bincount(slot_j, minlength=n)
    axis_names = [fm.AXES[a] + (" (normal)" if a == normal else "") for a in range(3)]
    links_by_axis = np.bincount(links_slot // n, minlength=3)
    t_break = (rec["step"] - first_step) * dt
    by_axis_time = {}
    for i in range(len(tbins) - 1):
        m = (t_break >= tbins[i]) & (t_break < tbins[i + 1])
        by_axis_time[f"{tbins[i]:g}-{tbins[i + 1]:g}"] = [int(c) for c in np.bincount(slot_ax[m], minlength=3)]
    single_link = single[slot_i] | single[slot_j]
    # singles' last break time by distance from the impact
    radius_time = {}
    for rb in range(len(rbins) - 1):
        m = single & (rcat == rb)
        tl = (last[m] - first_step) * dt
        radius_time[f"{rbins[rb]:g}-{rbins[rb + 1]:g}"] = [int(np.count_nonzero((tl >= tbins[i]) & (tl < tbins[i + 1])))
                                                        for i in range(len(tbins) - 1)]
    # sectors (as fracture_metrics: 45 degrees, centred on the in-plane axes) of the singles and all automata
    ang = np.degrees(np.arctan2(pos[:, pb] - centre[pb], pos[:, pa] - centre[pa])) % 360.0
    on_axis = ((np.floor((ang + 22.5) / 45.0).astype(int)) % 8) % 2 == 0
    band = (radius >= 0.25) & (radius <= 0.7)
    # across the axis cracks: automata 0.25-0.7 m from the impact along an in-plane axis, by their distance
    # from that axis's line through the impact point in rows of d (row 0 touches the line): mean damage,
    # share of singles
    dmg = fk["damage"].astype(float)
    da_, db_ = pos[:, pa] - centre[pa], pos[:, pb] - centre[pb]
    profile = []
    for row in range(6):
        m = np.zeros(n, dtype=bool)
        for along, off in ((da_, db_), (db_, da_)):
            m |= (np.abs(along) >= 0.25) & (np.abs(along) <= 0.7) & (np.floor(np.abs(off) / spacing + 1e-6) == row)
        profile.append([row, int(m.sum()), float(dmg[m].mean()) if m.any() else None,
                        float(single[m].mean()) if m.any() else None])
    # the singles' links in break order: steps between consecutive breaks of a single's links
    gaps = []
    for a in np.flatnonzero(single):
        m = (links_i == a) | (links_j == a)
        st = np.sort(broken_step[links_slot[m]])
        gaps.append(np.diff(st))
    gaps_last = np.array([g[-1] for g in gaps if len(g)])
    # the same for the singles' own final step: all their links broke in one step?
    res = {
        "run": os.path.abspath(run_dir), "origin": origin, "frame": k, "time": t_frame, "time_step": dt, "spacing": spacing,
        "automata": n, "breaks": int(len(rec)), "breaks_by": by, "first_break_step": first_step,
        "singles": int(single.sum()),
        "links_per_automaton": {"singles": share_table(degree, single, range(7)),},
        "single_spread_steps": {
            "all_in_one_step": int(np.count_nonzero(spread == 0)),
            "within_10": int(np.count_nonzero(spread <= 10)),
            "within_100": int(np.count_nonzero(spread <= 100)),
            "within_1000": int(np.count_nonzero(spread <= 1000)),
            "median": float(np.median(spread)) if len(spread) else None,
            "quartiles": [float(q) for q in np.percentile(spread, [25, 75])] if len(spread) else None,
        },
        "single_links_in_last_step": {str(v): int(np.count_nonzero(in_last[single] == v)) for v in range(1, 7)},
        "single_link_criteria": {"displacement": crit_single[0], "stress": crit_single[1]},
        "all_break_criteria": by,
        "single_class": share_table(cls, single, range(1, 5)),
        "single_class_beyond_0.25_m": share_table(cls[radius >= 0.25], single[radius >= 0.25], range(1, 5)),
        "single_link_weaker_end": weaker,
        "single_layer_across": share_table(across, single, range(int(across.max()) + 1)),
        "single_radius_bins_m": rbins,
        "single_radius": share_table(rcat, single, range(len(rbins) - 1)),
        "single_last_break_after_first_break_s": {
            f"{tbins[i]:g}-{tbins[i + 1]:g}": int(np.count_nonzero((t_last >= tbins[i]) & (t_last < tbins[i + 1])))
            for i in range(len(tbins) - 1)},
        "singles_over_time": over_time,
        "breaks_sharing_an_automaton_with_a_break_of_the_same_step": int(shared.sum()),
        "steps_with_breaks": int(np.count_nonzero(per_step)),
        "axis_names": axis_names,
        "profile_across_axis_cracks": profile,
        "single_last_break_by_radius_and_time": radius_time,
        "singles_in_annulus_on_axis_sectors": int(np.count_nonzero(single & band & on_axis)),
        "singles_in_annulus_on_diagonal_sectors": int(np.count_nonzero(single & band & ~on_axis)),
        "automata_in_annulus_on_axis_sectors": int(np.count_nonzero(band & on_axis)),
        "automata_in_annulus_on_diagonal_sectors": int(np.count_nonzero(band & ~on_axis)),
        "steps_between_last_two_breaks": {"median": float(np.median(gaps_last)) if len(gaps_last) else None,
                                          "within_10": int(np.count_nonzero(gaps_last <= 10)),
                                          "count": int(len(gaps_last))},
        "links_by_axis": [int(c) for c in links_by_axis],
        "broken_by_axis": [int(c) for c in np.bincount(slot_ax, minlength=3)],
        "broken_by_axis_singles_links": [int(c) for c in np.bincount(slot_ax[single_link], minlength=3)],
        "broken_by_axis_over_time_s": by_axis_time,
        "damaged_automata_by_broken_links": {str(v): int(np.count_nonzero(broken_per_automaton == v)) for v in range(1, 7)},
        "most_breaks_in_one_step": int(per_step.max()) if len(per_step) else 0,
    }
    return res


def report(r):
    L = []
    L.append(f"{r['run']}: frame {r['frame']} (t = {1e3 * r['time']:.1f} ms), dt = {r['time_step']:.3e} s, "
             f"{r['automata']} automata, {r['breaks']} breaks ({r['breaks_by']['displacement']} displacement, "
             f"{r['breaks_by']['stress']} stress), first in step {r['first_break_step']}")
    L.append(f"singles: {r['singles']}")
    L.append("  links at the start (singles of all automata; share of the singles/of all): " +
             ", ".join(f"{k}: {v[0]} of {v[2]} {v[1]:.2f}/{v[3]:.2f}" for k, v in r["links_per_automaton"]["singles"].items() if v[2] > 0))
    s = r["single_spread_steps"]
    L.append(f"  steps from its first to its last link break: 0 (all at once): {s['all_in_one_step']}, <= 10: "
             f"{s['within_10']}, <= 100: {s['within_100']}, <= 1000: {s['within_1000']}; median {s['median']}, "
             f"quartiles {s['quartiles']}")
    L.append("  links broken in its last step: " + ", ".join(f"{k}: {v}" for k, v in r["single_links_in_last_step"].items()))
    c = r["single_link_criteria"]
    tot = max(c["displacement"] + c["stress"], 1)
    a = r["all_break_criteria"]
    L.append(f"  its links' criteria: displacement {c['displacement']} ({100 * c['displacement'] / tot:.1f} %), stress "
             f"{c['stress']}; all breaks: displacement {100 * a['displacement'] / max(a['displacement'] + a['stress'], 1):.1f} %")
    L.append("  class (singles of all automata; share of the singles/of all): " +
             ", ".join(f"{k}: {v[0]} of {v[2]} {v[1]:.2f}/{v[3]:.2f}" for k, v in r["single_class"].items()))
    L.append(f"  the same beyond 0.25 m from {r['origin']}" + (" (without the plug): " if r["origin"] == "the impact" else ": ") +
             ", ".join(f"{k}: {v[0]} of {v[2]} {v[1]:.2f}/{v[3]:.2f}" for k, v in r["single_class_beyond_0.25_m"].items()))
    L.append("  its links by class, single against neighbour: " + ", ".join(f"{k} {v}" for k, v in r["single_link_weaker_end"].items()))
    L.append("  layer across the wall (0 = " + ("impact face" if r["origin"] == "the impact" else "the face at lowest y") +
             "; singles of all automata; share of the singles/of all): " +
             ", ".join(f"{k}: {v[0]} of {v[2]} {v[1]:.2f}/{v[3]:.2f}" for k, v in r["single_layer_across"].items()))
    rb = r["single_radius_bins_m"]
    L.append(f"  distance from {r['origin']} in the plane [m]: " +
             ", ".join(f"{rb[int(k)]:g}-{rb[int(k) + 1]:g}: {v[0]} of {v[2]} {v[1]:.2f}/{v[3]:.2f}" for k, v in r["single_radius"].items()))
    L.append("  last link broke after the first break [s]: " +
             ", ".join(f"{k}: {v}" for k, v in r["single_last_break_after_first_break_s"].items()))
    L.append("  singles by frame (ms: count): " + ", ".join(f"{1e3 * t:.0f}: {c}" for t, c in r["singles_over_time"]))
    L.append(f"breaks sharing an automaton with another break of the same step: "
             f"{r['breaks_sharing_an_automaton_with_a_break_of_the_same_step']} of {r['breaks']}; steps with breaks "
             f"{r['steps_with_breaks']}, most in one step {r['most_breaks_in_one_step']}")
    L.append("  singles' last break by distance [m] and time after the first break (bins as above): " + "; ".join(
        f"{k}: {v}" for k, v in r["single_last_break_by_radius_and_time"].items()))
    L.append(f"  singles in the 0.25-0.7 m annulus: axis sectors {r['singles_in_annulus_on_axis_sectors']} of "
             f"{r['automata_in_annulus_on_axis_sectors']}, diagonal sectors {r['singles_in_annulus_on_diagonal_sectors']} of "
             f"{r['automata_in_annulus_on_diagonal_sectors']}")
    g = r["steps_between_last_two_breaks"]
    L.append(f"  steps between its last two link breaks: median {g['median']}, <= 10 steps: {g['within_10']} of {g['count']}")
    L.append("across the axis cracks, 0.25-0.7 m out (row of d from the line: automata, mean damage, single share): " +
             "; ".join(f"{p[0]}: {p[1]}, {p[2]:.2f}, {p[3]:.2f}" if p[1] else f"{p[0]}: 0" for p in r["profile_across_axis_cracks"]))
    names = r["axis_names"]
    L.append("broken links by axis (broken / links): " + ", ".join(
        f"{names[a]}: {r['broken_by_axis'][a]} / {r['links_by_axis'][a]}" for a in range(3)) +
        "; of the singles' links: " + ", ".join(f"{names[a]}: {r['broken_by_axis_singles_links'][a]}" for a in range(3)))
    L.append("  by time after the first break [s] (x, y, z): " + ", ".join(
        f"{k}: {v}" for k, v in r["broken_by_axis_over_time_s"].items()))
    L.append("automata by broken links (1..6): " + ", ".join(f"{k}: {v}" for k, v in r["damaged_automata_by_broken_links"].items()))
    return "\n".join(L)


def main(argv=None):
    if hasattr(signal, "SIGPIPE"):  # `| head` ends the output quietly
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir")
    ap.add_argument("--frame", type=int, help="frame whose singles are studied (default last; a checkpoint of it must exist)")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    try:
        r = analyse(a.run_dir, a.frame)
    except (fm.RunError, OSError, KeyError, ValueError) as e:
        print(f"break_history.py: {e}", file=sys.stderr)
        return 2
    print(report(r))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(r, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
