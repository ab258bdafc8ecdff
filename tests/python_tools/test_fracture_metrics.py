"""Tests of tools/fracture_metrics.py on fake run folders with known answers (run with
/usr/bin/python3 -m pytest tests/python_tools)."""
import json
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools"))
import fracture_metrics as fm  # noqa: E402


def write_vtu(path, points, fields):
    """A .vtu in mca's layout (src/io/vtk_writer.cpp): appended raw blocks, each a UInt64 byte count then
    the bytes; offsets from the byte after '_'."""
    n = len(points)
    blocks, arrays, offset = [], [], 0

    def add(arr):
        nonlocal offset
        raw = np.ascontiguousarray(arr).tobytes()
        blocks.append(np.uint64(len(raw)).tobytes() + raw)
        at = offset
        offset += 8 + len(raw)
        return at

    xml = ['<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
           'header_type="UInt64">\n  <UnstructuredGrid>\n', f'    <Piece NumberOfPoints="{n}" NumberOfCells="{n}">\n',
           "      <PointData>\n"]
    for name, arr in fields.items():
        arr = np.asarray(arr)
        comps = 1 if arr.ndim == 1 else arr.shape[1]
        typ = "Float32" if arr.dtype.kind == "f" else "Int32"
        arr = arr.astype("<f4" if typ == "Float32" else "<i4")
        xml.append(f'        <DataArray type="{typ}" Name="{name}" NumberOfComponents="{comps}" format="appended" '
                   f'offset="{add(arr)}"/>\n')
    xml.append("      </PointData>\n      <Points>\n")
    xml.append('        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="appended" '
               f'offset="{add(np.asarray(points, "<f4"))}"/>\n')
    xml.append("      </Points>\n      <Cells>\n")
    conn = np.arange(n, dtype="<i4")
    xml.append(f'        <DataArray type="Int32" Name="connectivity" format="appended" offset="{add(conn)}"/>\n')
    xml.append(f'        <DataArray type="Int32" Name="offsets" format="appended" offset="{add(conn + 1)}"/>\n')
    xml.append(f'        <DataArray type="UInt8" Name="types" format="appended" offset="{add(np.ones(n, "u1"))}"/>\n')
    xml.append('      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding="raw">\n   _')
    with open(path, "wb") as f:
        f.write("".join(xml).encode())
        for b in blocks:
            f.write(b)
        f.write(b"\n  </AppendedData>\n</VTKFile>\n")


SCENE = """name = "fake"
[[object]]
name = "wall"
shape = "box"
size = [2.0, 0.2, 1.5]
position = [0.0, 0.0, 0.75]
[[projectile]]
name = "ball"
radius = 0.2
position = [0.1, -0.4, 0.8]
velocity = [0.0, 30.0, 0.0]
"""

# Damaged shares by sector (0, 45, ..., 315 degrees): axes 0.75, 0.5, 1.0, 0.75 (mean 0.75),
# diagonals 0.25, 0.5, 0.0, 0.25 (mean 0.25): ratio 3.
SHARES = [0.75, 0.25, 0.5, 0.5, 1.0, 0.0, 0.75, 0.25]
CENTRE = np.array([0.1, 0.0, 0.8])  # the projectile's path through the wall's centre plane y = 0


def fake_run(tmp_path, with_fragments=True):
    """Points in eight sectors of the xz plane around CENTRE, 8 per sector, inside the annulus, damaged
    as SHARES says; decoys (damaged, outside the annulus or on the sector's edge, or of a second object)
    that a wrong radius, angle or object test would count; four undamaged corners that make the first
    object's box (1.0 m and more from CENTRE in the plane) hold the issue's annulus; every point displaced
    so that a reader using the points, not the initial positions, gets other sectors and radii."""
    pts, dmg = [], []
    for k, share in enumerate(SHARES):
        for i in range(8):
            r = 0.3 + 0.05 * i
            ang = math.radians(45 * k + (-20 + 5 * i))  # within +-22.5 degrees of the sector's centre
            pts.append(CENTRE + [r * math.cos(ang), 0.05 * (i % 3 - 1), r * math.sin(ang)])
            # damaged: 1.0 or exactly the threshold 0.5 (counted: damage >= 0.5); undamaged: 0.4 or 0
            dmg.append((0.5 if i % 2 else 1.0) if i < round(8 * share) else (0.4 if i % 2 else 0.0))
    for r in (0.1, 0.2, 0.72, 0.9):  # outside the annulus, all damaged, on the diagonals
        for k in (1, 3, 5, 7):
            ang = math.radians(45 * k)
            pts.append(CENTRE + [r * math.cos(ang), 0.0, r * math.sin(ang)])
            dmg.append(1.0)
    for dx, dz in ((-1.2, -1.0), (1.2, -1.0), (-1.2, 1.0), (1.2, 1.0)):  # the first object's corners
        pts.append(CENTRE + [dx, 0.0, dz])
        dmg.append(0.0)
    n_first = len(pts)
    for k in (1, 3, 5, 7):  # a second object's automata in the annulus on the diagonals, all damaged
        ang = math.radians(45 * k)
        pts.append(CENTRE + [0.5 * math.cos(ang), 1.0, 0.5 * math.sin(ang)])
        dmg.append(1.0)
    obj = np.array([0] * n_first + [1] * (len(pts) - n_first), dtype=np.int32)
    initial = np.array(pts)
    rng = np.random.default_rng(3)
    disp = np.column_stack([rng.uniform(0.3, 0.6, len(pts)), rng.uniform(-1, 1, len(pts)),
                            rng.uniform(-0.6, -0.3, len(pts))])
    frames = tmp_path / "frames"
    frames.mkdir()
    # frame 0: undamaged, frame 1: the pattern
    for f, d in ((0, np.zeros(len(pts))), (1, np.array(dmg))):
        write_vtu(frames / f"automata_{f:06d}.vtu", initial + (disp if f else 0),
                  {"velocity": np.zeros((len(pts), 3)), "displacement": disp if f else np.zeros((len(pts), 3)),
                   "strength_class": np.full(len(pts), 4, dtype=np.int32), "object": obj, "damage": d,
                   "radius": np.full(len(pts), 0.025)})
    (tmp_path / "automata.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        '  <Collection>\n'
        '    <DataSet timestep="0" group="" part="0" file="frames/automata_000000.vtu"/>\n'
        '    <DataSet timestep="0.002" group="" part="0" file="frames/automata_000001.vtu"/>\n'
        '  </Collection>\n</VTKFile>\n')
    (tmp_path / "scene.toml").write_text(SCENE)
    return tmp_path


def write_fragments(path, sizes, unit=0.3):
    cols = ("id,automata,mass,volume,centre_x,centre_y,centre_z,velocity_x,velocity_y,velocity_z,"
            "box_min_x,box_min_y,box_min_z,box_max_x,box_max_y,box_max_z")
    rows = [cols]
    for i, s in enumerate(sorted(sizes, reverse=True)):
        rows.append(f"{i},{s},{s * unit!r}," + ",".join(["0"] * 13))
    path.write_text("\n".join(rows) + "\n")


def test_vtu_reader_round_trip(tmp_path):
    pts = np.array([[0, 0, 0], [1.5, -2, 3], [1e3, 0.25, -7]], float)
    write_vtu(tmp_path / "a.vtu", pts, {"damage": np.array([0.0, 0.5, 1.0]),
                                        "strength_class": np.array([1, 2, 4], dtype=np.int32),
                                        "velocity": np.arange(9.0).reshape(3, 3)})
    v = fm.read_vtu(tmp_path / "a.vtu")
    np.testing.assert_array_equal(v["Points"], pts.astype(np.float32))
    np.testing.assert_array_equal(v["damage"], [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(v["strength_class"], [1, 2, 4])
    np.testing.assert_array_equal(v["velocity"], np.arange(9.0).reshape(3, 3))
    assert "connectivity" not in v


def test_impact_point_and_plane_from_scene(tmp_path):
    fake_run(tmp_path)
    axis, centre = fm.impact_geometry(fm.read_scene(str(tmp_path)))
    assert axis == 1
    np.testing.assert_allclose(centre, CENTRE)


def test_sector_shares_and_ratio(tmp_path):
    fake_run(tmp_path)
    d = fm.damage_measure(str(tmp_path))
    assert d["frame"] == 1 and d["time"] == 0.002
    assert d["automata_in_annulus"] == 64
    assert d["sector_automata"] == [8] * 8
    np.testing.assert_allclose(d["sector_shares"], SHARES)
    assert d["axis_mean"] == pytest.approx(0.75)
    assert d["diagonal_mean"] == pytest.approx(0.25)
    assert d["axis_diagonal_ratio"] == pytest.approx(3.0)


def test_earlier_frame_and_threshold(tmp_path):
    fake_run(tmp_path)
    d0 = fm.damage_measure(str(tmp_path), frame=0)
    assert d0["sector_damaged"] == [0] * 8
    # threshold 0.3 also counts the automata at damage 0.4 (odd i among the undamaged ones)
    d = fm.damage_measure(str(tmp_path), threshold=0.3)
    assert d["sector_damaged"][5] == 4 and d["sector_damaged"][4] == 8


def sample_power_law(tau, s_max, n1):
    """Sizes s = 1 .. s_max, round(n1 * s^-tau) fragments of each."""
    sizes = []
    for s in range(1, s_max + 1):
        sizes += [s] * int(round(n1 * s ** -tau))
    return sizes


@pytest.mark.parametrize("tau", [1.6, 1.8, 2.0])
def test_power_law_fit_recovers_tau(tmp_path, tau):
    # sizes 1 .. 127: seven whole bins [1], [2, 3], ..., [64, 127]
    sizes = sample_power_law(tau, 127, 1.0e4)
    n = sum(sizes)
    sizes += [n]  # one body as large as all the debris: half the mass
    write_fragments(tmp_path / "fragments.csv", sizes)
    f = fm.fragment_measure(str(tmp_path), fit_max=127)
    fit = f["fit"]
    assert fit["tau"] == pytest.approx(tau, abs=0.02)
    assert fit["r2"] > 0.999
    assert fit["bins_fitted"] == 7 and fit["empty_bins_in_range"] == 0
    # decades between the first fitted point (m = 1) and the last (sqrt(64 * 127))
    assert fit["decades"] == pytest.approx(math.log10(math.sqrt(64 * 127)))
    assert f["largest_mass_share"] == pytest.approx(0.5)
    assert f["above_tenth_count"] == 1
    # the default range (up to N/10) takes the same seven bins and reports the empty ones above them
    fit = fm.fragment_measure(str(tmp_path))["fit"]
    assert fit["tau"] == pytest.approx(tau, abs=0.02)
    assert fit["bins_fitted"] == 7 and fit["empty_bins_in_range"] > 0


def test_mass_shares_by_size(tmp_path):
    # 100 automata: 20 singles, 2 of 5, 1 of 10 (= N/10, counted as mid), 1 of 9, 1 of 51
    sizes = [1] * 20 + [5, 5, 10, 9, 51]
    assert sum(sizes) == 100
    write_fragments(tmp_path / "fragments.csv", sizes)
    f = fm.fragment_measure(str(tmp_path))
    assert f["automata"] == 100 and f["fragments"] == 25
    assert f["single_count"] == 20 and f["single_mass_share"] == pytest.approx(0.20)
    assert f["small_2_9_count"] == 3 and f["small_2_9_mass_share"] == pytest.approx(0.19)
    assert f["mid_count"] == 1 and f["mid_mass_share"] == pytest.approx(0.10)
    assert f["largest_automata"] == 51 and f["largest_mass_share"] == pytest.approx(0.51)
    counts = {b["lo"]: b["count"] for b in f["bins"]}
    assert counts == {1: 20, 2: 0, 4: 2, 8: 2, 16: 0, 32: 1}


def test_gaps_are_reported_not_fitted(tmp_path):
    # singles and pairs, then nothing until the large body: two bins fitted, the rest in range empty
    sizes = [1] * 400 + [2] * 100 + [3] * 20 + [4000]
    write_fragments(tmp_path / "fragments.csv", sizes)
    fit = fm.fragment_measure(str(tmp_path))["fit"]
    assert fit["bins_fitted"] == 2
    assert fit["empty_bins_in_range"] == fit["bins_in_range"] - 2 > 0
    # densities 400 at m = 1 and 120 / 2 = 60 at m = sqrt(6): tau = log(400 / 60) / log(sqrt 6)
    assert fit["tau"] == pytest.approx(math.log(400 / 60) / math.log(math.sqrt(6)))
    assert fit["decades"] == pytest.approx(math.log10(math.sqrt(6)))
    assert fit["tau_stderr"] is None and fit["r2"] is None  # two points: a line through both says nothing


def test_command_line_json_and_plot(tmp_path):
    run = fake_run(tmp_path)
    write_fragments(run / "fragments.csv", sample_power_law(1.8, 127, 1e4) + [20000])
    out, png = tmp_path / "m.json", tmp_path / "m.png"
    assert fm.main([str(run), "--json", str(out), "--plot", str(png)]) == 0
    res = json.loads(out.read_text())
    assert res["damage"]["axis_diagonal_ratio"] == pytest.approx(3.0)
    assert res["fragments"]["fit"]["tau"] == pytest.approx(1.8, abs=0.02)
    assert png.stat().st_size > 1000


def test_missing_folder_is_an_error(tmp_path, capsys):
    assert fm.main([str(tmp_path / "nothing")]) == 2
    assert "not a folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert fm.main([str(tmp_path / "empty")]) == 2


def test_radii_that_make_no_annulus_are_refused(tmp_path, capsys):
    for args, words in ((["--r-in", "0.5", "--r-out", "0.1"], "the inner radius must be below the outer one"),
                        (["--r-in", "nan"], "--r-in nan: give a finite number >= 0"),
                        (["--threshold", "-1"], "--threshold -1: give a finite number >= 0")):
        with pytest.raises(SystemExit) as e:
            fm.main([str(tmp_path)] + args)
        assert e.value.code == 2
        assert words in capsys.readouterr().err


def plate(half=0.2, d=0.05, layers=2):
    """Initial positions and radii of a square plate 2 * half wide in the xz plane, centred on the origin,
    `layers` automata of spacing d through y."""
    c = np.arange(-half + d / 2, half, d)
    pts = np.array([[x, d * (k - (layers - 1) / 2), z] for x in c for z in c for k in range(layers)])
    return pts, np.full(len(pts), d / 2)


def test_annulus_radii_follow_the_object(tmp_path):
    # the default wall, struck 0.75 m from its top and bottom edges, keeps the 0.25-0.7 m
    wall = np.array([[x, 0.0, z] for x in np.arange(-0.975, 1.0, 0.05) for z in np.arange(0.025, 1.5, 0.05)])
    r_in, r_out, half, scaled = fm.annulus_radii(wall, np.full(len(wall), 0.025), 1, np.array([0.0, 0.0, 0.75]))
    assert (r_in, r_out, scaled) == (0.25, 0.7, False)
    assert half == pytest.approx(0.75)
    # a 0.4 m plate struck at its centre: 0.25 and 0.7 of its half-width 0.2 m
    pts, rad = plate()
    r_in, r_out, half, scaled = fm.annulus_radii(pts, rad, 1, np.zeros(3))
    assert scaled and half == pytest.approx(0.2)
    assert (r_in, r_out) == pytest.approx((0.05, 0.14))
    # struck off centre: the nearest edge decides
    r_in, r_out, half, scaled = fm.annulus_radii(pts, rad, 1, np.array([0.1, 0.0, 0.0]))
    assert half == pytest.approx(0.1) and r_out == pytest.approx(0.07)
    with pytest.raises(fm.RunError, match="outside the first object"):
        fm.annulus_radii(pts, rad, 1, np.array([0.5, 0.0, 0.0]))


def test_plate_sectors_with_scaled_radii():
    # 8 x 8 automata per layer: 5 per quadrant and layer lie 0.05-0.14 m out, off the edge rows; with
    # 2 layers 8 per axis sector, 2 per diagonal one (as mca's CrackIsotropy.TheAnnulusScalesOnASmallPlate)
    pts, rad = plate()
    r_in, r_out, _, _ = fm.annulus_radii(pts, rad, 1, np.zeros(3))
    res = fm.sector_shares(pts, np.zeros(len(pts)), 1, np.zeros(3), r_in=r_in, r_out=r_out)
    assert res["sector_automata"] == [8, 2] * 4
    # two automata a diagonal sector: too few for a share, so null with the reason, and the result is valid JSON
    assert res["axis_diagonal_ratio"] is None
    assert "fewer than 5 automata in the sectors at 45 (2), 135 (2), 225 (2), 315 (2)" in res["reason"]
    json.dumps(res, allow_nan=False)


def test_an_undamaged_annulus_has_its_own_reason():
    # five automata in each sector, none damaged: not an unbounded ratio, nothing to measure
    ang = np.radians(np.repeat(np.arange(8) * 45.0, 5))
    pts = np.stack([0.5 * np.cos(ang), np.zeros(len(ang)), 0.5 * np.sin(ang)], axis=1)
    res = fm.sector_shares(pts, np.zeros(len(pts)), 1, np.zeros(3))
    assert res["sector_automata"] == [5] * 8
    assert res["axis_diagonal_ratio"] is None and "no automaton of the annulus is damaged" in res["reason"]
    damage = np.where(np.arange(len(pts)) % 10 < 5, 1.0, 0.0)  # the axis sectors' automata
    res = fm.sector_shares(pts, damage, 1, np.zeros(3))
    assert res["axis_diagonal_ratio"] is None and "unbounded" in res["reason"]


def test_singles_of_unequal_mass_have_no_fit(tmp_path):
    # rubble of a random lattice, whose cells differ in volume: singles of 0.5 to 1.75 mean masses fill the
    # bins of 1 and 2-3 automata; a line through them would fit the cells' spread (as mca's
    # FragmentMassDistribution.SinglesOfUnequalMassHaveNoFit)
    cols = ("id,automata,mass,volume,centre_x,centre_y,centre_z,velocity_x,velocity_y,velocity_z,"
            "box_min_x,box_min_y,box_min_z,box_max_x,box_max_y,box_max_z")
    masses = [0.3 * (1.75 if k < 10 else 0.5 if k < 20 else 1.0) for k in range(100)]
    rows = [cols] + [f"{i},1,{m!r}," + ",".join(["0"] * 13) for i, m in enumerate(sorted(masses, reverse=True))]
    (tmp_path / "fragments.csv").write_text("\n".join(rows) + "\n")
    f = fm.fragment_measure(str(tmp_path))
    assert [b["count"] for b in f["bins"]] == [90, 10]
    fit = f["fit"]
    assert fit["tau"] is None and fit["decades"] is None and fit["bins_fitted"] == 0
    assert "every fragment is a single automaton" in fit["reason"]
    assert fm.summary_form(f)["power_law"]["decades"] is None


def test_an_empty_sector_is_null_not_nan():
    pts = np.array([[0.5, 0, 0], [0, 0, 0.5], [-0.5, 0, 0], [0.35, 0, 0.35]])
    res = fm.sector_shares(pts, np.array([1.0, 1.0, 0.0, 1.0]), 1, np.zeros(3))
    assert res["sector_automata"] == [1, 1, 1, 0, 1, 0, 0, 0]
    assert res["sector_shares"][3] is None and res["axis_mean"] is None and res["axis_diagonal_ratio"] is None
    assert "sectors at 135, 225, 270, 315 degrees" in res["reason"]
    json.dumps(res, allow_nan=False)
    assert "ratio: none" in fm.report({"damage": dict(res, frame=0, time=0.0)})


def test_sizes_round_to_whole_automata(tmp_path):
    # two materials: N = 1024 automata of 1026 kg; 0.4 kg is 0.399 mean automata (first bin, not none),
    # 1.9 kg is 1.896 (the 2-3 bin), 1023.7 kg is 1021.7 (the 512-1023 bin)
    cols = ("id,automata,mass,volume,centre_x,centre_y,centre_z,velocity_x,velocity_y,velocity_z,"
            "box_min_x,box_min_y,box_min_z,box_max_x,box_max_y,box_max_z")
    rows = [cols] + [f"{i},{n},{m!r}," + ",".join(["0"] * 13) for i, (n, m) in enumerate([(1000, 1023.7), (1, 1.9), (23, 0.4)])]
    (tmp_path / "fragments.csv").write_text("\n".join(rows) + "\n")
    f = fm.fragment_measure(str(tmp_path))
    counts = [b["count"] for b in f["bins"]]
    assert counts == [1, 1, 0, 0, 0, 0, 0, 0, 0, 1]
    assert sum(b["mass_share"] for b in f["bins"]) == pytest.approx(1.0)
    assert f["bins"][1]["mass_share"] == pytest.approx(1.9 / 1026)
    # the largest is the heaviest fragment, with its own automata count
    assert f["largest_automata"] == 1000 and f["largest_mass_share"] == pytest.approx(1023.7 / 1026)
    # just under a power of two in mean automata: the bin of that power, which the bins reach
    rows = [cols, "0,1024,1023.6," + ",".join(["0"] * 13), "1,1,1.0," + ",".join(["0"] * 13)]
    (tmp_path / "fragments.csv").write_text("\n".join(rows) + "\n")
    f = fm.fragment_measure(str(tmp_path))
    assert len(f["bins"]) == 11 and f["bins"][10]["count"] == 1


def test_equal_densities_have_no_r2(tmp_path):
    write_fragments(tmp_path / "fragments.csv", [1] * 4 + [2] * 8 + [500])
    fit = fm.fragment_measure(str(tmp_path))["fit"]
    assert fit["tau"] == pytest.approx(0.0, abs=1e-12)
    assert fit["r2"] is None and fit["tau_stderr"] is None


def test_no_fit_gives_a_reason(tmp_path):
    write_fragments(tmp_path / "fragments.csv", [100])
    f = fm.fragment_measure(str(tmp_path))
    assert f["fit"]["tau"] is None and "0 non-empty bins of at most 10 automata" in f["fit"]["reason"]
    assert "no fit (0 non-empty bins" in fm.report({"fragments": f})


def test_the_fragments_say_when_they_are_from(tmp_path, capsys):
    """fragments.csv holds where the run ended: the report says so, and that an earlier frame's damage is
    not of that moment."""
    run = fake_run(tmp_path)
    write_fragments(run / "fragments.csv", [1, 1, 2, 50])
    (run / "summary.json").write_text(json.dumps({"simulated_time": 0.002, "status": "finished"}))
    assert fm.main([str(run)]) == 0
    out = capsys.readouterr().out
    assert "fragments (at the run's end, t = 2.0 ms; fragments.csv)" in out
    assert fm.main([str(run), "--frame", "0"]) == 0
    assert "fragments (at the run's end, t = 2.0 ms; not frame 0; fragments.csv)" in capsys.readouterr().out
    (run / "summary.json").write_text(json.dumps({"simulated_time": 0.002, "status": "interrupted"}))
    assert fm.main([str(run), "--json", str(tmp_path / "m.json")]) == 0
    assert "where the run stopped: interrupted, t = 2.0 ms" in capsys.readouterr().out
    # One radius given past the rule's other one: no annulus, an error (it reported 0 automata, exit 0).
    assert fm.main([str(run), "--r-in", "100"]) == 2
    assert "is empty: give an inner radius below the outer one" in capsys.readouterr().err
    res = json.loads((tmp_path / "m.json").read_text())
    assert res["fragments"]["time"] == 0.002 and res["fragments"]["status"] == "interrupted"
    # An output into a folder that does not exist is refused before anything is measured.
    assert fm.main([str(run), "--json", str(tmp_path / "none" / "m.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
