#!/usr/bin/env python3
"""Plots of an `mca run` output folder, as PNG in its render/ folder (called by `mca run --render`):

  render/energies.png       kinetic, elastic, contact and projectile energies and the balance over time
  render/broken_links.png   broken links (by criterion) and fragments over time
  render/fragment_masses.png  cumulative fragment mass distribution (log-log): the number of fragments of
                              at least mass m, against m

Reads stats.csv and fragments.csv. Each file is written under a temporary name and renamed.
Usage: python3 tools/plot_run.py OUT_DIR [--quiet]
"""
import csv
import os
import sys


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise SystemExit(f"plot_run.py: {path} has no rows")
    return rows


def save(fig, path):
    tmp = f"{path}.{os.getpid()}.0.tmp"
    fig.savefig(tmp, dpi=100, format="png")
    os.replace(tmp, path)


def main(argv):
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
    stats = read_csv(os.path.join(out, "stats.csv"))
    render = os.path.join(out, "render")
    os.makedirs(render, exist_ok=True)
    t = [1e3 * float(r["time"]) for r in stats]

    def col(name):
        return [float(r[name]) for r in stats]

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
    ax.plot(t, col("broken_stress"), label="by equivalent stress", lw=1.2)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("broken links")
    ax2 = ax.twinx()
    ax2.plot(t, col("fragments"), color="grey", ls="--", label="fragments")
    ax2.set_ylabel("fragments")
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], fontsize=8, loc="upper left")
    ax.set_title("Broken links and fragments")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save(fig, os.path.join(render, "broken_links.png"))
    plt.close(fig)

    frags = read_csv(os.path.join(out, "fragments.csv"))
    masses = sorted((float(r["mass"]) for r in frags), reverse=True)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    # N(>= m): the k-th heaviest fragment has k fragments at least as heavy.
    ax.step(masses, range(1, len(masses) + 1), where="post")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("fragment mass m [kg]")
    ax.set_ylabel("fragments of mass >= m")
    ax.set_title(f"Fragment masses at the end ({len(masses)} fragments)")
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    save(fig, os.path.join(render, "fragment_masses.png"))
    plt.close(fig)
    if not quiet:
        print(f"plots: energies.png, broken_links.png, fragment_masses.png in {render}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
