#!/usr/bin/env python3
"""Fragment mass distributions of several runs side by side, with the published band (issue 21's figure).

One panel per group of runs; in each, the number density n(m) of every run's fragment_mass_distribution
(summary.json; README, "Outputs") in its own colour, masses in kg, densities per kg of mass range, and
the published exponents of 3D brittle impact fragmentation, tau 1.5-2.1, as a shaded band through the
singles' bin of the group's first run. Filled points are the bins up to N/10 (those the fit uses), open
ones the bins above.

Usage:
  /usr/bin/python3 tools/fragment_spectra.py --out FIG.png "TITLE=LABEL:RUN_DIR,LABEL:RUN_DIR,..." ...

Example (docs/fracture-study.md, section 5):
  tools/fragment_spectra.py --out docs/figures/fragment_masses_speeds.png \\
      "instant break (the paper's)=15 m/s:out/v15,30 m/s:out/v30,60 m/s:out/v60,120 m/s:out/v120" \\
      "fracture_energy = 100=15 m/s:out/v15_g100,..."
A run folder whose summary.json is missing or has no distribution ends it with a message and exit status 1.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_run import TAU_BAND, read_summary, save  # noqa: E402


def distribution(run):
    path = os.path.join(run, "summary.json")
    dist = read_summary(run, "fragment_spectra.py").get("fragment_mass_distribution")
    if dist is not None and not isinstance(dist, dict):
        raise SystemExit(f"fragment_spectra.py: {path}: fragment_mass_distribution is not an object: damaged")
    if not dist or dist.get("reason"):
        raise SystemExit(f"fragment_spectra.py: {path} has no fragment mass distribution"
                         f"{': ' + dist['reason'] if dist and dist.get('reason') else ''}")
    return dist


def parse_group(text):
    title, sep, runs = text.rpartition("=")  # (a title may hold "=", the runs do not)
    if not sep or not runs:
        raise SystemExit(f"fragment_spectra.py: a group is TITLE=LABEL:RUN,...; got {text!r}")
    # (',', '=' and a first ':' are the syntax's: a folder named with them is given through a link.)
    names = ("; a folder whose name holds ',' or '=' cannot be given in this form: give a symbolic link to it, or "
             "rename it")
    out = []
    for item in runs.split(","):
        label, sep, run = item.partition(":")
        if not sep:
            raise SystemExit(f"fragment_spectra.py: a run is LABEL:RUN_DIR; got {item!r}{names}")
        if not os.path.isdir(run):
            raise SystemExit(f"fragment_spectra.py: {run!r} (the run labelled {label!r}) is not a folder{names}")
        out.append((label, run))
    return title, out


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("groups", nargs="+")
    args = ap.parse_args(argv)
    groups = [parse_group(g) for g in args.groups]
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise SystemExit("fragment_spectra.py: matplotlib is not installed; install it with `apt-get install "
                         "python3-matplotlib` (scripts/setup.sh does)")

    fig, axes = plt.subplots(1, len(groups), figsize=(6.5 * len(groups), 5), sharey=True, squeeze=False)
    for ax, (title, runs) in zip(axes[0], groups):
        ax.set_xscale("log")
        ax.set_yscale("log")
        first = None
        for k, (label, run) in enumerate(runs):
            dist = distribution(run)
            unit = dist["automaton_mass"]
            fit_max = dist["power_law"]["fit_max_automata"]
            bins = [b for b in dist["bins"] if b["count"] > 0]
            inside = [b for b in bins if b["automata_max"] <= fit_max]
            outside = [b for b in bins if b["automata_max"] > fit_max]
            colour = f"C{k}"
            tau = dist["power_law"]["tau"]
            name = f"{label}: tau {tau:.2f}" if tau is not None else f"{label}: no fit"
            ax.plot([b["abscissa_kg"] for b in inside], [b["number_density"] / unit for b in inside], "o-",
                    color=colour, label=name)
            ax.plot([b["abscissa_kg"] for b in outside], [b["number_density"] / unit for b in outside], "s",
                    mfc="none", color=colour)
            if first is None and bins:
                first = (bins[0]["abscissa_kg"], bins[0]["number_density"] / unit,
                         max(b["abscissa_kg"] for b in bins))
        if first:
            x0, y0, x1 = first[0], first[1], first[2] * 1.5
            xs = [x0 * (x1 / x0) ** (i / 49) for i in range(50)]
            ax.fill_between(xs, [y0 * (x / x0) ** -TAU_BAND[0] for x in xs],
                            [y0 * (x / x0) ** -TAU_BAND[1] for x in xs], color="orange", alpha=0.25, lw=0,
                            label=f"published band, tau {TAU_BAND[0]}-{TAU_BAND[1]}")
        ax.set_title(title)
        ax.set_xlabel("fragment mass m [kg]")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    axes[0][0].set_ylabel("n(m): fragments per kg of mass range")
    fig.tight_layout()
    save(fig, args.out, "fragment_spectra.py")
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
