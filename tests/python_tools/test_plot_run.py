"""Tests of tools/plot_run.py: render/fragment_masses.png draws summary.json's fragment_mass_distribution
(n(m) in kg, the fit over its range, the published band tau 1.5-2.1) (run with /usr/bin/python3 -m pytest
tests/python_tools)."""
import json
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools"))
import fracture_metrics as fm  # noqa: E402
import plot_run  # noqa: E402

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

from test_fracture_metrics import sample_power_law, write_fragments  # noqa: E402

UNIT = 0.3  # kg per automaton in write_fragments


def distribution(tmp_path, sizes):
    """fragment_mass_distribution as summary.json has it, for these fragment sizes (one material)."""
    write_fragments(tmp_path / "fragments.csv", sizes, UNIT)
    return fm.summary_form(fm.fragment_measure(str(tmp_path)))


def test_density_fit_and_band_are_drawn_in_kg(tmp_path):
    sizes = sample_power_law(1.8, 127, 1e4)
    sizes += [sum(sizes)]  # a body above N/10: drawn, not fitted
    dist = distribution(tmp_path, sizes)
    fig = plot_run.mass_distribution_figure(plt, dist, "test")
    ax = fig.axes[0]
    def line(prefix):
        found = [ln for ln in ax.get_lines() if ln.get_label().startswith(prefix)]
        assert len(found) == 1, [ln.get_label() for ln in ax.get_lines()]
        return found[0]

    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    # the bins: abscissa in kg, density per kg = per automaton / UNIT
    fitted = [b for b in dist["bins"] if b["count"] > 0 and b["automata_max"] <= dist["power_law"]["fit_max_automata"]]
    x, y = line("n(m), bins up to").get_data()
    np.testing.assert_allclose(x, [b["abscissa_automata"] * UNIT for b in fitted], rtol=1e-12)
    np.testing.assert_allclose(y, [b["number_density"] / UNIT for b in fitted], rtol=1e-12)
    # the fit: from the first to the last fitted abscissa, slope -tau in log-log, through the prefactor
    fit = dist["power_law"]
    fx, fy = (np.asarray(v, float) for v in line("fit:").get_data())
    assert fx[0] == pytest.approx(fit["range_kg"][0]) and fx[-1] == pytest.approx(fit["range_kg"][1])
    slope = np.polyfit(np.log10(fx), np.log10(fy), 1)[0]
    assert slope == pytest.approx(-fit["tau"], rel=1e-9)
    assert fy[0] == pytest.approx(10 ** fit["log10_prefactor"] * (fx[0] / UNIT) ** -fit["tau"] / UNIT)
    assert "tau = 1.8" in line("fit:").get_label()
    # the band: a shaded polygon from the first bin, its edges falling with tau 1.5 and 2.1
    bands = [c for c in ax.collections if isinstance(c, PolyCollection) and "published band" in c.get_label()]
    assert len(bands) == 1 and "1.5-2.1" in bands[0].get_label()
    verts = bands[0].get_paths()[0].vertices
    x0 = fitted[0]["abscissa_automata"] * UNIT
    right = verts[np.isclose(verts[:, 0], verts[:, 0].max())][:, 1]
    x1 = verts[:, 0].max()
    y0 = fitted[0]["number_density"] / UNIT
    assert [right.min(), right.max()] == pytest.approx([y0 * (x1 / x0) ** -2.1, y0 * (x1 / x0) ** -1.5])
    # the body above N/10, drawn as an open square
    bx, _ = line("n(m), bins above").get_data()
    assert list(bx) == pytest.approx([dist["bins"][-1]["abscissa_kg"]])
    # the end of the fit range, N/10, as a vertical line in kg
    assert line("N/10").get_xdata()[0] == pytest.approx(fit["fit_max_automata"] * UNIT)
    plt.close(fig)


def test_no_fit_says_why(tmp_path):
    dist = distribution(tmp_path, [1] * 50)
    assert dist["power_law"]["tau"] is None
    fig = plot_run.mass_distribution_figure(plt, dist, "singles only")
    labels = [ln.get_label() for ln in fig.axes[0].get_lines()]
    assert any(lb.startswith("no fit: 1 non-empty bin") for lb in labels), labels
    assert not any(lb.startswith("fit") for lb in labels)
    plt.close(fig)


def test_the_legend_stands_clear_of_the_points(tmp_path):
    """A lone fragment's point stood under the legend in the upper right: the legend goes to a corner clear of
    every point (the upper right where that is clear, as for a spectrum falling to the right)."""
    for sizes, corner in (([480], None), (sample_power_law(1.8, 127, 1e4) + [20000], "upper right")):
        dist = distribution(tmp_path, sizes)
        fig = plot_run.mass_distribution_figure(plt, dist, "legend")
        ax = fig.axes[0]
        fig.canvas.draw()
        box = ax.get_legend().get_window_extent()
        points = [ax.transData.transform(p) for ln in ax.get_lines() if ln.get_label().startswith("n(m)")
                  for p in zip(*ln.get_data())]
        assert points
        assert not any(box.contains(x, y) for x, y in points), (sizes[:3], box, points)
        if corner:
            axes = ax.get_window_extent()
            assert box.x1 > axes.x0 + 0.8 * axes.width and box.y1 > axes.y0 + 0.8 * axes.height, corner
        plt.close(fig)


def test_a_legend_no_corner_leaves_room_for_goes_below_the_plot(tmp_path):
    """Points in all four corners: the legend goes below the axes (it stood over a point in the upper right)."""
    dist = distribution(tmp_path, sample_power_law(1.8, 127, 1e4) + [20000])
    full = [b for b in dist["bins"] if b["count"] > 0]
    top = max(b["number_density"] for b in full) * 10
    for b, density in ((full[1], top * 1e-9), (full[-2], top * 1e-9), (full[-1], top)):
        b["number_density"] = density
    full[0]["number_density"] = top
    fig = plot_run.mass_distribution_figure(plt, dist, "corners")
    ax = fig.axes[0]
    fig.canvas.draw()
    assert ax.get_legend().get_window_extent().y1 <= ax.get_window_extent().y0
    plt.close(fig)


def test_bins_that_cannot_be_drawn_are_left_out_with_a_word(tmp_path, capsys):
    """A bin with a NaN, infinite, zero or missing density or mass (a hand-edited summary) was dropped from the
    log axes without a word: it is left out with a warning that counts it, and the rest is drawn."""
    dist = distribution(tmp_path, sample_power_law(1.8, 127, 1e4))
    full = [b for b in dist["bins"] if b["count"] > 0]
    full[1]["number_density"] = float("nan")
    full[2]["number_density"] = 0
    full[3]["abscissa_kg"] = float("inf")
    del full[4]["number_density"]
    fig = plot_run.mass_distribution_figure(plt, dist, "damaged")
    err = capsys.readouterr().err
    assert f"4 of the {len(full)} non-empty bins" in err, err
    points = [p for ln in fig.axes[0].get_lines() if ln.get_label().startswith("n(m)") for p in zip(*ln.get_data())]
    assert len(points) == len(full) - 4 and all(math.isfinite(x) and math.isfinite(y) for x, y in points)
    plt.close(fig)


def test_a_long_reason_is_wrapped(tmp_path):
    fig = plot_run.mass_distribution_figure(plt, {"reason": "no fragments " * 30}, "reason")
    (text,) = fig.axes[0].texts
    assert max(len(line) for line in text.get_text().splitlines()) <= 90
    plt.close(fig)


def write_run(out, dist):
    cols = ["frame", "time", "kinetic_energy", "elastic_energy", "contact_energy", "projectile_kinetic_energy",
            "total_energy", "energy_balance", "broken_displacement", "broken_stress", "broken_total", "fragments"]
    rows = [",".join(cols)] + [",".join(str(i * (c != "time") + 0.001 * i * (c == "time")) for c in cols) for i in range(3)]
    (out / "stats.csv").write_text("\n".join(rows) + "\n")
    summary = {"scene": "fake", "status": "finished"}
    if dist is not None:
        summary["fragment_mass_distribution"] = dist
    (out / "summary.json").write_text(json.dumps(summary))


def test_main_writes_the_three_plots(tmp_path):
    dist = distribution(tmp_path, sample_power_law(1.8, 127, 1e3) + [5000])
    write_run(tmp_path, dist)
    assert plot_run.main(["plot_run.py", str(tmp_path), "--quiet"]) == 0
    for name in ("energies.png", "broken_links.png", "fragment_masses.png"):
        path = tmp_path / "render" / name
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    assert not list((tmp_path / "render").glob("*.tmp"))


def test_a_summary_without_the_distribution_is_refused_by_name(tmp_path):
    write_run(tmp_path, None)
    with pytest.raises(SystemExit) as e:
        plot_run.main(["plot_run.py", str(tmp_path), "--quiet"])
    assert "fragment_mass_distribution" in str(e.value)


def refusal(path):
    with pytest.raises(SystemExit) as e:
        plot_run.main(["plot_run.py", str(path), "--quiet"])
    return str(e.value)


def test_a_folder_that_is_not_a_whole_run_is_refused_in_one_line_before_anything_is_drawn(tmp_path):
    assert "is not a folder" in refusal(tmp_path / "none")
    (tmp_path / "empty").mkdir()
    assert "has no stats.csv" in refusal(tmp_path / "empty")
    # A run killed before its end (no summary.json): the message names mca resume, and no plot is drawn.
    killed = tmp_path / "killed"
    killed.mkdir()
    write_run(killed, distribution(killed, [1, 1, 2]))
    (killed / "summary.json").unlink()
    message = refusal(killed)
    assert "has no summary.json" in message and f"mca resume {killed}" in message
    assert not (killed / "render").exists()
    (killed / "summary.json").write_text("[]")
    assert "is not a JSON object" in refusal(killed)
    (killed / "summary.json").write_text('{"scene": ')
    assert "cannot read" in refusal(killed)
    # A damaged row inside stats.csv is refused by its number.
    write_run(killed, distribution(killed, [1, 1, 2]))
    rows = (killed / "stats.csv").read_text().splitlines()
    cells = rows[2].split(",")
    cells[2] = "x"  # kinetic_energy
    rows[2] = ",".join(cells)
    (killed / "stats.csv").write_text("\n".join(rows) + "\n")
    assert "row 2" in refusal(killed)
    assert not (killed / "render").exists()


def test_rows_out_of_order_repeated_or_infinite_are_refused_by_number(tmp_path):
    write_run(tmp_path, distribution(tmp_path, [1, 1, 2]))
    rows = (tmp_path / "stats.csv").read_text().splitlines()
    (tmp_path / "stats.csv").write_text("\n".join(rows + [rows[-1]]) + "\n")
    assert "row 4: frame 2 at time 0.002 s does not follow frame 2 at 0.002 s" in refusal(tmp_path)
    (tmp_path / "stats.csv").write_text("\n".join([rows[0], rows[2], rows[1], rows[3]]) + "\n")
    assert "row 2: frame 0 " in refusal(tmp_path)
    cells = rows[2].split(",")
    cells[2] = "inf"  # kinetic_energy
    (tmp_path / "stats.csv").write_text("\n".join([rows[0], rows[1], ",".join(cells), rows[3]]) + "\n")
    assert "row 2: kinetic_energy is 'inf', not a finite number" in refusal(tmp_path)
    assert not (tmp_path / "render").exists()
    # A gap (rows a resume could not make again) is plotted.
    (tmp_path / "stats.csv").write_text("\n".join([rows[0], rows[1], rows[3]]) + "\n")
    assert plot_run.main(["plot_run.py", str(tmp_path), "--quiet"]) == 0


def test_a_last_row_cut_short_is_left_out_with_a_warning(tmp_path, capsys):
    write_run(tmp_path, distribution(tmp_path, [1, 1, 2]))
    text = (tmp_path / "stats.csv").read_text()
    (tmp_path / "stats.csv").write_text(text[: len(text) - 9])
    assert plot_run.main(["plot_run.py", str(tmp_path), "--quiet"]) == 0
    assert "the last row" in capsys.readouterr().err
    assert (tmp_path / "render" / "energies.png").exists()


def test_with_parent_it_ends_with_that_process_and_draws_nothing_after(tmp_path):
    """--parent=PID (mca passes its own): a script whose parent is gone (mca killed with -9) ends without
    drawing, so it never writes into the folder of a later run. Here the parent, a shell, is killed 0.3 s
    after it started the script, which is then importing matplotlib, past its request for the death signal
    (without it, the plots were drawn a second later); a script slower to start finds its parent gone. Either
    way no plot is written and it ends within seconds."""
    import subprocess
    import time

    dist = distribution(tmp_path, sample_power_law(1.8, 127, 1e3) + [5000])
    write_run(tmp_path, dist)
    script = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "plot_run.py")
    pidfile = tmp_path / "child.pid"
    parent = subprocess.Popen(["/bin/sh", "-c", f'{sys.executable} {script} {tmp_path} --quiet --parent=$$ & '
                               f'echo $! > {pidfile}; sleep 0.3; kill -9 $$'])
    parent.wait()
    child = int(pidfile.read_text())
    for _ in range(200):  # up to 10 s
        try:
            with open(f"/proc/{child}/stat") as f:
                if f.read().split(")")[-1].split()[0] == "Z":
                    break
        except FileNotFoundError:
            break
        time.sleep(0.05)
    else:
        pytest.fail("the plot script outlived its parent by 10 s")
    time.sleep(0.5)
    assert not (tmp_path / "render").exists() or not list((tmp_path / "render").glob("*.png"))


def test_with_another_process_as_parent_it_ends_at_once(tmp_path):
    write_run(tmp_path, distribution(tmp_path, sample_power_law(1.8, 127, 1e3) + [5000]))
    with pytest.raises(SystemExit) as e:
        plot_run.main(["plot_run.py", str(tmp_path), "--quiet", f"--parent={os.getpid() + 1000000}"])
    assert e.value.code == 0
    assert not (tmp_path / "render").exists()
