#!/usr/bin/env python3
"""One Markdown table row per run folder, from tools/fracture_metrics.py and tools/break_history.py: the
tables of docs/fracture-study.md.

Usage: /usr/bin/python3 tools/fracture_study_table.py [--table spectrum|singles|sectors] RUN_DIR...
(singles needs each run's last checkpoint: run with --checkpoint-every N.)
"""
import argparse
import json
import os
import signal
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import break_history as bh  # noqa: E402
import fracture_metrics as fm  # noqa: E402


def name(run):
    return os.path.basename(os.path.normpath(run))


def spectrum(runs):
    print("| run | broken links | fragments | singles (mass %) | 2-9 automata (mass %) | 10 to N/10 (mass %) | "
          "above N/10 (automata) | largest % | tau +- se | R^2 | bins fitted (empty in range) | decades |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for run in runs:
        s = json.load(open(os.path.join(run, "summary.json")))
        f = fm.fragment_measure(run)
        fit = f["fit"]
        tau = "-" if fit["tau"] is None else f"{fit['tau']:.2f} +- {fit['tau_stderr']:.2f}" if fit["tau_stderr"] else f"{fit['tau']:.2f}"
        r2 = "-" if fit["r2"] is None else f"{fit['r2']:.3f}"
        print(f"| {name(run)} | {s['broken_links']['total']:,} | {f['fragments']:,} | {f['single_count']:,} "
              f"({100 * f['single_mass_share']:.1f}) | {f['small_2_9_count']} ({100 * f['small_2_9_mass_share']:.1f}) | "
              f"{f['mid_count']} ({100 * f['mid_mass_share']:.1f}) | {', '.join(f'{a:,}' for a in f['above_tenth_sizes'])} | "
              f"{100 * f['largest_mass_share']:.1f} | {tau} | {r2} | {fit['bins_fitted']} ({fit['empty_bins_in_range']}) | "
              f"{'-' if fit['decades'] is None else format(fit['decades'], '.2f')} |")


def sectors(runs):
    print("| run | frame (ms) | 0 | 45 | 90 | 135 | 180 | 225 | 270 | 315 | axes mean | diagonals mean | ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for run in runs:
        d = fm.damage_measure(run)
        ratio = "-" if d["axis_diagonal_ratio"] is None else f"{d['axis_diagonal_ratio']:.2f}"
        print(f"| {name(run)} | {1e3 * d['time']:.0f} | " + " | ".join(fm._fmt_share(x) for x in d["sector_shares"]) +
              f" | {fm._fmt_share(d['axis_mean'])} | {fm._fmt_share(d['diagonal_mean'])} | {ratio} |")


def singles(runs):
    print("| run | broken links | singles | per broken link | within 0.25 m (of all there) | 0.25-0.7 m on axis / "
          "diagonal sectors | beyond 0.7 m | all links in one step | last two breaks <= 10 steps apart | "
          "median steps first to last break | single's class weaker / equal / stronger than the neighbour |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for run in runs:
        r = bh.analyse(run)
        rad = r["single_radius"]
        beyond = rad["3"][0] + rad["4"][0]
        w = r["single_link_weaker_end"]
        print(f"| {name(run)} | {r['breaks']:,} | {r['singles']:,} | {r['singles'] / max(r['breaks'], 1):.3f} | "
              f"{rad['0'][0]:,} ({rad['0'][2]:,}) | {r['singles_in_annulus_on_axis_sectors']:,} / "
              f"{r['singles_in_annulus_on_diagonal_sectors']:,} | {beyond:,} | {r['single_spread_steps']['all_in_one_step']} | "
              f"{r['steps_between_last_two_breaks']['within_10']:,} | {r['single_spread_steps']['median']:.0f} | "
              f"{w['single weaker']:,} / {w['equal']:,} / {w['single stronger']:,} |")


def main(argv=None):
    if hasattr(signal, "SIGPIPE"):  # `| head` ends the output quietly
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--table", choices=["spectrum", "singles", "sectors"], default="spectrum")
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args(argv)
    try:
        {"spectrum": spectrum, "singles": singles, "sectors": sectors}[a.table](a.runs)
    except (fm.RunError, OSError, KeyError, ValueError) as e:
        print(f"fracture_study_table.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
