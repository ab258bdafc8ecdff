#!/usr/bin/env python3
"""Plots of an `mca run` output folder, as PNG in its render/ folder (called by `mca run --render`):

  render/energies.png       kinetic, elastic, contact and projectile energies and the balance over time
  render/broken_links.png   broken links (by criterion) and fragments over time
  render/fragment_masses.png  the fragment mass distribution of summary.json's fragment_mass_distribution:
                              the number density n(m) in logarithmic bins (log-log, per kg), the fitted
                              power law n(m) ~ m^-tau over its range, and the published exponents of 3D
                              brittle impact fragmentation, tau 1.5-2.1, as a shaded band

Reads stats.csv and summary.json; a folder without them, or with them damaged, ends the script with one
line before anything is drawn. Each file is written under a temporary name and renamed.
Usage: python3 tools/plot_run.py OUT_DIR [--quiet] [--parent=PID]
(--parent: mca's process id; the script ends when that process does, killed or not, so that it never
writes into the folder of a later run.)
"""
import csv
import json
import os
import math
import sys
import textwrap

TAU_BAND = (1.5, 2.1)  # published 3D brittle impact fragmentation exponents (issue 21)


COLUMNS = ["frame", "time", "kinetic_energy", "elastic_energy", "contact_energy", "projectile_kinetic_energy",
           "total_energy", "energy_balance", "broken_total", "broken_displacement", "broken_stress", "fragments"]


def number(text):
    try:
        v = float(text)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None  # (nan, inf: not a number to plot)


def read_run(out):
    """stats.csv's rows (the columns plotted, as floats) and summary.json of run folder `out`; anything missing
    or damaged ends the script with one line naming the file, before any plot is drawn."""
    if not os.path.isdir(out):
        raise SystemExit(f"plot_run.py: {out} is not a folder; give the output folder of an mca run")
    path = os.path.join(out, "stats.csv")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except FileNotFoundError:
        raise SystemExit(f"plot_run.py: {out} has no stats.csv: not the output folder of an mca run, or one that "
                         "stopped before its first frame")
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise SystemExit(f"plot_run.py: cannot read {path}: {e}")
    missing = [c for c in COLUMNS if rows and c not in rows[0]]
    if not rows or missing:
        raise SystemExit(f"plot_run.py: {path} has " + ("no rows" if not rows else f"no column {missing[0]}") +
                         ": not written by this mca, or damaged")
    table = []
    for k, r in enumerate(rows):
        values = {c: number(r.get(c)) for c in COLUMNS}
        if None in values.values():
            bad = next(c for c in COLUMNS if values[c] is None)
            if k == len(rows) - 1 and k > 0:  # a last row cut short (a copy, a disk that filled): left out
                print(f"plot_run.py: warning: the last row of {path} is cut short (no {bad}); plotted without it",
                      file=sys.stderr)
                break
            raise SystemExit(f"plot_run.py: {path}, row {k + 1}: {bad} is {r.get(bad)!r}, not a finite number: "
                             "damaged")
        # Frames in order, each once (a resume that lost rows leaves a gap, never a repeat).
        if table and not (values["frame"] > table[-1]["frame"] and values["time"] > table[-1]["time"]):
            last = table[-1]
            raise SystemExit(f"plot_run.py: {path}, row {k + 1}: frame {values['frame']:g} at time "
                             f"{values['time']:g} s does not follow frame {last['frame']:g} at {last['time']:g} s: "
                             "rows repeated or out of order, damaged or edited")
        table.append(values)
    summary = read_summary(out, "plot_run.py")
    if not isinstance(summary.get("fragment_mass_distribution"), dict):
        raise SystemExit(f"plot_run.py: {os.path.join(out, 'summary.json')} has no fragment_mass_distribution "
                         "(written by an older mca, or damaged): run the scene again")
    return table, summary


def read_summary(out, tool):
    """summary.json of run folder `out` as a dict; a missing, unreadable or damaged one ends the script with one
    line (`tool`: the script it names)."""
    path = os.path.join(out, "summary.json")
    try:
        with open(path, encoding="utf-8") as f:
            summary = json.load(f)
    except FileNotFoundError:
        raise SystemExit(f"{tool}: {out} has no summary.json: the run was killed before its end (mca writes it at "
                         "the end, at a Ctrl-C and when a run stops on an error); its checkpoints, if any, continue "
                         f"it: mca resume {out}")
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise SystemExit(f"{tool}: cannot read {path}: {e}")
    if not isinstance(summary, dict):
        raise SystemExit(f"{tool}: {path} is not a JSON object: not written by mca, or damaged")
    return summary


def save(fig, path, tool="plot_run.py"):
    """fig as PNG at path, through a temporary name; a write that fails (a full disk) ends the script with
    one line naming the file and the reason, and leaves no temporary."""
    tmp = f"{path}.{os.getpid()}.0.tmp"
    try:
        fig.savefig(tmp, dpi=100, format="png")
        os.replace(tmp, path)
    except OSError as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise SystemExit(f"{tool}: could not write {path}: {e.strerror or e}; check free disk space and the "
                         "output folder")


def mass_distribution_figure(plt, dist, title):
    """The figure of n(m) of a fragment_mass_distribution object (summary.json; README, "Outputs") with its
    fit and the published band. Masses in kg, densities in fragments per kg of mass range: the summary's
    per-automaton numbers over the automaton's mass. Its lines carry labels starting "n(m)" (the bins),
    "fit" and "N/10"; the band is the collection labelled "published band"."""
    fig, ax = plt.subplots(figsize=(8, 5))
    if dist.get("reason"):
        ax.text(0.5, 0.5, textwrap.fill(f"no fragment mass distribution: {dist['reason']}", 90), ha="center",
                va="center", transform=ax.transAxes)
        ax.set_axis_off()
        ax.set_title(title)
        fig.tight_layout()
        return fig
    unit = dist["automaton_mass"]
    fit = dist["power_law"]
    fit_max = fit["fit_max_automata"]
    full = [b for b in dist["bins"] if b["count"] > 0]
    # A bin whose mass or density is not a positive finite number (a hand-edited or damaged summary) has no
    # place on log axes: left out, with a word (matplotlib dropped it silently).
    drawable = [b for b in full if all((number(b.get(k)) or 0) > 0 for k in ("abscissa_kg", "number_density"))]
    if len(drawable) < len(full):
        print(f"plot_run.py: warning: {len(full) - len(drawable)} of the {len(full)} non-empty bins of "
              "fragment_mass_distribution have a mass or density that is not a positive number (damaged or edited): "
              "drawn without them", file=sys.stderr)
        full = drawable
    inside = [b for b in full if b["automata_max"] <= fit_max]
    outside = [b for b in full if b["automata_max"] > fit_max]

    def xy(bins):
        return [b["abscissa_kg"] for b in bins], [b["number_density"] / unit for b in bins]

    ax.set_xscale("log")
    ax.set_yscale("log")
    if inside:
        ax.plot(*xy(inside), "o", color="C0", label=f"n(m), bins up to N/10 = {fit_max:g} automata")
    if outside:
        ax.plot(*xy(outside), "s", mfc="none", color="C0", label="n(m), bins above N/10 (not fitted)")
    if full:
        # The band through the first non-empty bin (the singles, where there are any): where n(m) would
        # fall with the published exponents.
        x0, y0 = full[0]["abscissa_kg"], full[0]["number_density"] / unit
        x1 = max(b["abscissa_kg"] for b in full) * 1.5
        xs = [x0 * (x1 / x0) ** (i / 49) for i in range(50)]
        ax.fill_between(xs, [y0 * (x / x0) ** -TAU_BAND[0] for x in xs], [y0 * (x / x0) ** -TAU_BAND[1] for x in xs],
                        color="orange", alpha=0.25, lw=0, label=f"published band, tau {TAU_BAND[0]}-{TAU_BAND[1]}")
    fit_points = []  # the fit's line, which the legend keeps clear of
    if fit["tau"] is not None:
        k0, k1 = fit["range_kg"]
        xs = [k0 * (k1 / k0) ** (i / 19) for i in range(20)]
        # log10 n = log10_prefactor - tau log10 m, m in automata and n per automaton; per kg: over unit
        ys = [10 ** fit["log10_prefactor"] * (x / unit) ** -fit["tau"] / unit for x in xs]
        fit_points = list(zip(xs, ys))
        se = "" if fit["tau_stderr"] is None else f" +- {fit['tau_stderr']:.2f}"
        r2 = "-" if fit["r2"] is None else f"{fit['r2']:.3f}"
        ax.plot(xs, ys, "-", color="C3", lw=2,
                label=f"fit: tau = {fit['tau']:.2f}{se}, R^2 = {r2}, {fit['bins_fitted']} bins "
                      f"({fit['empty_bins_in_range']} empty in range), {fit['decades']:.2f} decades")
    else:
        # the reason, in the legend, wrapped to stay clear of the points
        ax.plot([], [], " ", label=textwrap.fill(f"no fit: {fit['reason']}", 60))
    ax.axvline(fit_max * unit, color="grey", ls=":", lw=1, label="N/10: the end of the fit range")
    ax.set_xlabel("fragment mass m [kg]")
    ax.set_ylabel("n(m): fragments per kg of mass range")
    mid = dist["fragments_10_to_tenth"]
    ax.set_title(f"{title}\n{dist['fragments']} fragment{'' if dist['fragments'] == 1 else 's'}; singles {100 * dist['singles']['mass_share']:.1f} %, "
                 f"10 automata to N/10 {100 * mid['mass_share']:.1f} %, largest {100 * dist['largest']['mass_share']:.1f} % "
                 "of the mass", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    # The legend in the upper right, the corner n(m) falling to the right leaves empty, else in the first other
    # corner clear of the points and the fit's line (a lone fragment's point stood under it), else below the
    # plot.
    points = [ax.transData.transform(p) for bins in (inside, outside) for p in zip(*xy(bins))]
    points += [ax.transData.transform(p) for p in fit_points]
    for loc in ("upper right", "lower left", "upper left", "lower right"):
        legend = ax.legend(fontsize=8, loc=loc)
        fig.canvas.draw()
        box = legend.get_window_extent().padded(8)
        if not any(box.contains(x, y) for x, y in points):
            break
    else:
        legend.remove()
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
        fig.set_size_inches(8, 6)
        fig.tight_layout()
    return fig


def plot_mass_distribution(plt, dist, path, title, tool="plot_run.py"):
    """mass_distribution_figure written to path (`tool`: the script named in an error)."""
    fig = mass_distribution_figure(plt, dist, title)
    save(fig, path, tool)
    plt.close(fig)


def end_with_parent(argv):
    """With --parent=PID, asks Linux to stop this process when that one ends (PR_SET_PDEATHSIG), and ends
    at once where it has ended already."""
    pids = [a.split("=", 1)[1] for a in argv[1:] if a.startswith("--parent=")]
    if not pids:
        return
    import ctypes
    import signal

    pr_set_pdeathsig = 1
    try:
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):
        pass  # not Linux: the parent's own time limit and stop remain
    if str(os.getppid()) != pids[0]:
        sys.exit(0)


def main(argv):
    end_with_parent(argv)
    args = [a for a in argv[1:] if not a.startswith("--")]
    quiet = "--quiet" in argv
    if len(args) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    out = args[0]
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_run.py: matplotlib is not installed; install it with `apt-get install python3-matplotlib` "
              "(scripts/setup.sh does)", file=sys.stderr)
        return 3
    stats, summary = read_run(out)
    render = os.path.join(out, "render")
    try:
        os.makedirs(render, exist_ok=True)
    except OSError as e:
        raise SystemExit(f"plot_run.py: cannot make {render}: {e.strerror or e}")
    t = [1e3 * r["time"] for r in stats]

    def col(name):
        return [r[name] for r in stats]

    def top_of(name):  # an axis from 0 to a little above the column's largest value (1 when all are 0)
        return max(1.0, 1.05 * max(col(name), default=0))

    fig, ax = plt.subplots(figsize=(8, 4.5))
    for name, label in [("kinetic_energy", "kinetic (automata)"), ("elastic_energy", "elastic"),
                        ("contact_energy", "contact"), ("projectile_kinetic_energy", "kinetic (projectiles)"),
                        ("total_energy", "total"), ("energy_balance", "balance (total - work put in)")]:
        ax.plot(t, col(name), label=label, lw=2 if name == "total_energy" else 1.2)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("energy [J]")
    ax.set_title("Energies")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, os.path.join(render, "energies.png"))
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(t, col("broken_total"), label="broken links (total)", lw=2)
    ax.plot(t, col("broken_displacement"), label="by displacement", lw=1.2)
    ax.plot(t, col("broken_stress"), label="by stress (a cubic link's equivalent stress, a random link's own)", lw=1.2)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("broken links")
    ax.set_ylim(0, top_of("broken_total"))
    ax2 = ax.twinx()
    ax2.plot(t, col("fragments"), color="grey", ls="--", label="fragments")
    ax2.set_ylabel("fragments")
    ax2.set_ylim(0, top_of("fragments"))
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    # the counts rise early and level off: the middle right is where they leave room
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], fontsize=8, loc="center right")
    ax.set_title("Broken links and fragments")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save(fig, os.path.join(render, "broken_links.png"))
    plt.close(fig)

    # (summary.json is written at the run's end, or where it stopped: an interrupted run's is not the end.)
    when = "at the end"
    if summary.get("status") != "finished":
        t_end = number(summary.get("simulated_time"))
        when = f"at t = {1e3 * t_end:.4g} ms (the run {summary.get('status', 'stopped')})" if t_end is not None else \
            f"where the run stopped ({summary.get('status', 'not finished')})"
    plot_mass_distribution(plt, summary["fragment_mass_distribution"], os.path.join(render, "fragment_masses.png"),
                           f"Fragment masses {when}: {summary.get('scene', '')}")
    if not quiet:
        print(f"plots: energies.png, broken_links.png, fragment_masses.png in {render}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
