"""Checkpoints, frames and pictures as the command writes them."""
import json
import os
import struct
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import mca
from conftest import run_command


def test_checkpoint_and_resume_continue_bitwise(tmp_path):
    a = mca.Simulation(mca.Scene.default(), threads=2)
    a.advance(3400)  # the ball strikes
    a.checkpoint(tmp_path / "at3400.mcack")
    a.advance(1600)
    b = mca.Simulation.resume(tmp_path / "at3400.mcack", threads=1)
    assert b.step == 3400
    b.advance(1600)
    assert b.state_hash() == a.state_hash()
    assert np.array_equal(b.positions(), a.positions())


def test_a_damaged_checkpoint_is_refused(tmp_path):
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    sim.checkpoint(tmp_path / "c.mcack")
    data = (tmp_path / "c.mcack").read_bytes()
    (tmp_path / "cut.mcack").write_bytes(data[: len(data) // 2])
    with pytest.raises(mca.Error, match="cut.mcack"):
        mca.Simulation.resume(tmp_path / "cut.mcack")
    # A file the user names that is no checkpoint: the fix is another file, not to move it out of a folder.
    (tmp_path / "scene.toml").write_text("name = 'x'\n")
    with pytest.raises(mca.Error, match=r"scene\.toml' is not an mca checkpoint \(bad header\): give a \.mcack file"):
        mca.Simulation.resume(tmp_path / "scene.toml")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(mca.Error, match="no checkpoint in"):
        mca.Simulation.resume(empty)
    # A folder of checkpoints by other names (as the README's example saves one) is not a run's: they are
    # named ("no checkpoint in" it was false).
    sim.checkpoint(empty / "at20ms.mcack")
    with pytest.raises(mca.Error, match=r"which holds .*at20ms\.mcack: give the checkpoint's path"):
        mca.Simulation.resume(empty)


def test_resume_a_command_run_folder(tmp_path, mca_binary):
    out = tmp_path / "run"
    run_command(mca_binary, "run", "--steps", 2000, "--checkpoint-every", 1, "--no-vtk", "--quiet", "--out", out)
    summary = json.loads((out / "summary.json").read_text())
    sim = mca.Simulation.resume(out, threads=2)  # the newest checkpoint: the last frame's
    assert sim.step == summary["steps"]
    assert sim.state_hash() == summary["state_hash"]


def test_write_frame_writes_the_commands_files(tmp_path, mca_binary):
    scene = mca.Scene.default()
    sim = mca.Simulation(scene, threads=2)
    out = tmp_path / "frames_out"
    assert sim.write_frame(out) == 0
    sim.advance(sim.steps_per_frame)
    assert sim.write_frame(out) == 1
    for name in ("frames/automata_000000.vtu", "frames/automata_000001.vtu", "frames/projectiles_000001.vtu",
                 "automata.pvd", "projectiles.pvd", "stats.csv", "scene.toml"):
        assert (out / name).is_file(), name
    assert mca.Scene.load(out / "scene.toml") == scene
    rows = (out / "stats.csv").read_text().splitlines()
    assert len(rows) == 3  # header and two frames
    pvd = ET.parse(out / "automata.pvd").getroot()
    assert [d.get("file") for d in pvd.iter("DataSet")] == ["frames/automata_000000.vtu", "frames/automata_000001.vtu"]
    # The command's frame 1 of the same scene is the same file.
    run = tmp_path / "run"
    run_command(mca_binary, "run", "--steps", sim.steps_per_frame, "--quiet", "--out", run)
    assert (run / "frames/automata_000001.vtu").read_bytes() == (out / "frames/automata_000001.vtu").read_bytes()
    # The folder is locked while the simulation writes into it, as a run's.
    r = __import__("subprocess").run([str(mca_binary), "run", "--steps", "1", "--quiet", "--out", str(out)],
                                     capture_output=True, text=True)
    assert r.returncode != 0 and str(out) in r.stderr
    sim.close_output()
    run_command(mca_binary, "run", "--steps", "1", "--quiet", "--out", out)


def png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_render_draws_the_state(tmp_path):
    sim = mca.Simulation(mca.Scene.default(), threads=2)
    sim.advance(6000)  # the ball strikes after about 3,400 steps
    image = mca.render(sim, tmp_path / "f.png", colour="damage", size=(320, 240))
    assert image.shape == (240, 320, 4) and image.dtype == np.uint8
    assert png_size(tmp_path / "f.png") == (320, 240)
    # Not empty: the ball in the middle (red), the damaged wall around it, the legend and the overlay.
    r, g, b, _ = image[120, 160].astype(int)
    assert r > 2 * g and r > 2 * b, image[120, 160]
    assert len(np.unique(image.reshape(-1, 4), axis=0)) > 50
    # The wall's damage shows: against the same camera at the start (no link broken, the ball away from
    # the wall), a good share of the pixels differ.
    start = mca.render(mca.Simulation(mca.Scene.default(), threads=1), colour="damage", size=(320, 240))
    assert np.any(image != start, axis=2).mean() > 0.05
    again = mca.render(sim, size=(320, 240), colour="damage")
    assert np.array_equal(again, image)  # rendering only reads the state
    spheres = mca.render(sim, draw="spheres", size=(320, 240))
    assert not np.array_equal(spheres, image)


def test_render_and_checkpoint_refuse_bad_paths(tmp_path):
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    with pytest.raises(mca.Error, match=r"render: path = '\.png' is the extension \.png alone, with no name before"):
        mca.render(sim, ".png")
    with pytest.raises(mca.Error, match=r"render: path = '.*x\.jpg' does not end in \.png"):
        mca.render(sim, tmp_path / "x.jpg", size=(64, 48))
    assert not (tmp_path / "x.jpg").exists()
    (tmp_path / "d.png").mkdir()
    with pytest.raises(mca.Error, match=r"render: path = '.*d\.png' is a folder; give the path of the PNG file"):
        mca.render(sim, tmp_path / "d.png", size=(64, 48))
    with pytest.raises(mca.Error, match=r"checkpoint: path = '.*' is a folder; give the path of the checkpoint file"):
        sim.checkpoint(tmp_path)
    with pytest.raises(mca.Error, match=r'checkpoint: path is empty \(""\)'):
        sim.checkpoint("")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.png"]
    assert list((tmp_path / "d.png").iterdir()) == []


def test_write_frame_refuses_the_folders_a_new_run_refuses(tmp_path, mca_binary):
    """write_frame makes the checks of a new run before it removes anything (it replaced a user's files in a
    folder of no run of mca, and removed the frames of a run that did not finish, which then could not be
    resumed: the hostile review of 2026-12-06)."""
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    foreign = tmp_path / "foreign"
    (foreign / "frames").mkdir(parents=True)
    (foreign / "frames" / "automata_000000.vtu").write_text("my own data")
    with pytest.raises(mca.Error, match=r"holds frames/automata_000000\.vtu, of the names a run of mca writes, but "
                                        r"no run of mca .*Give write_frame another folder"):
        sim.write_frame(foreign)
    assert (foreign / "frames" / "automata_000000.vtu").read_text() == "my own data"
    assert not (foreign / "scene.toml").exists()
    # A run stopped before its end: its checkpoints, and no summary of a finished run.
    unfinished = tmp_path / "unfinished"
    run_command(mca_binary, "run", "--steps", 2 * sim.steps_per_frame, "--checkpoint-every", 1, "--quiet", "--out",
                unfinished)
    (unfinished / "summary.json").unlink()
    frames = sorted(p.name for p in (unfinished / "frames").iterdir())
    with pytest.raises(mca.Error, match=r"holds a run that did not finish .*; continue it with: mca\.Simulation\."
                                        r"resume\(\".*unfinished\"\) and its write_frame\(\".*unfinished\"\), or "
                                        r"mca resume .*unfinished\. To start it afresh"):
        sim.write_frame(unfinished)
    assert sorted(p.name for p in (unfinished / "frames").iterdir()) == frames
    run_command(mca_binary, "resume", "--quiet", unfinished)  # (still resumes)


def test_write_frame_refuses_a_folder_whose_subfolders_hold_the_scenes_mesh(tmp_path):
    """A mesh the scene read, in a subfolder write_frame clears (an earlier run's fragment mesh), is refused
    before anything is removed: it was deleted, and the folder's scene.toml named a file no longer there
    (a hostile review, 2026-12-06; mca run and mca resume refuse the same)."""
    out = tmp_path / "out"
    (out / "fragments").mkdir(parents=True)
    mesh = out / "fragments" / "fragment_000.off"
    mesh.write_text("OFF\n8 6 0\n" + "".join(f"{x} {y} {z}\n" for z in (0, 0.2) for y in (0, 0.2) for x in (0, 0.2)) +
                    "4 0 2 3 1\n4 4 5 7 6\n4 0 1 5 4\n4 2 6 7 3\n4 0 4 6 2\n4 1 3 7 5\n")
    scene = mca.Scene.from_toml(f'[solver]\nspacing = 0.05\n[[object]]\nname = "rock"\nshape = "mesh"\n'
                                f'mesh = "{mesh}"\n')
    sim = mca.Simulation(scene, threads=1)
    with pytest.raises(mca.Error, match=r"object\[0\]\.mesh = '.*fragment_000\.off' lies in '.*fragments', where the "
                                        r"run writes the fragments' meshes"):
        sim.write_frame(out)
    assert mesh.exists()
    assert not (out / "scene.toml").exists()


def test_write_frame_knows_its_folder_however_it_is_spelt(tmp_path, monkeypatch):
    """"out/" or "./out" after "out" is the same folder: its frames go on (it was taken for another folder and
    started afresh, its frames removed: the hostile review of 2026-12-06)."""
    monkeypatch.chdir(tmp_path)
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    assert sim.write_frame("out") == 0
    sim.advance(1)
    assert sim.write_frame("out/") == 1
    sim.advance(1)
    assert sim.write_frame("./out") == 2
    assert sim.write_frame(tmp_path / "x" / ".." / "out") == 3
    assert [p.name for p in sorted((tmp_path / "out" / "frames").glob("automata_*.vtu"))] == [
        f"automata_00000{k}.vtu" for k in range(4)]
    with pytest.raises(mca.Error, match=r'write_frame: the folder is empty \(""\)'):
        sim.write_frame("")


def test_mca_resume_names_a_checkpoint_saved_between_frames(tmp_path, mca_binary):
    """A checkpoint the module saved between two frames is no damaged file: mca resume says where it was
    saved and that mca.Simulation.resume continues it (it said 'the file is damaged or was edited': the
    hostile review of 2026-12-06)."""
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    out = tmp_path / "run"
    sim.write_frame(out)
    sim.advance(500)
    sim.write_frame(out)
    (out / "checkpoints").mkdir()
    sim.checkpoint(out / "checkpoints" / "frame_000001.mcack")
    sim.close_output()
    r = __import__("subprocess").run([str(mca_binary), "resume", "--quiet", str(out)], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert f"its state is at step 500, between frames 0 and 1 (steps 0 and {sim.steps_per_frame})" in r.stderr
    assert "continue it with mca.Simulation.resume in Python" in r.stderr
    assert "damaged" not in r.stderr
    resumed = mca.Simulation.resume(out / "checkpoints" / "frame_000001.mcack")
    assert resumed.step == 500
    # Nor can its frames go on from it in its folder (the checkpoint's frame would be another state).
    stats = (out / "stats.csv").read_bytes()
    with pytest.raises(mca.Error, match=r"its state is at step 500, between frames 0 and 1 .*: it was saved between "
                                        r"frames .*, and a run's frames go on in its folder from the end of a frame: "
                                        r"give write_frame another folder"):
        resumed.write_frame(out)
    assert (out / "stats.csv").read_bytes() == stats


def test_a_killed_run_goes_on_from_python_in_its_own_folder(tmp_path, mca_binary, monkeypatch):
    """A Simulation resumed from a run folder's checkpoint writes its frames on in that folder, as mca resume
    does: the frames, rows and collection entries the killed run wrote past the checkpoint are written again,
    on the run's frame clock and up to its end, and the folder ends as the run's uninterrupted twin
    (write_frame refused it as a run that did not finish, naming mca resume: the hostile review of
    2026-12-06, F5; frames off the clock, a relative path after os.chdir and the run's end: 2026-12-08)."""
    scene = mca.Scene.default()
    scene.output.frame_rate = 5000
    scene_file = tmp_path / "fast.toml"
    scene.save(scene_file)
    spf = mca.Simulation(scene, threads=1).steps_per_frame
    whole, out = tmp_path / "whole", tmp_path / "killed"
    for folder in (whole, out):
        run_command(mca_binary, "run", scene_file, "--steps", 4 * spf, "--checkpoint-every", 1, "--quiet", "--out",
                    folder)
    # Killed after frame 4 was written, before its checkpoint was: the run's end and that checkpoint missing.
    (out / "summary.json").unlink()
    (out / "fragments.csv").unlink()
    stats = (out / "stats.csv").read_bytes()
    # From a checkpoint before the newest it cannot go on (the newest would be of frames no longer there).
    older = mca.Simulation.resume(out / "checkpoints" / "frame_000003.mcack", threads=1)
    with pytest.raises(mca.Error, match=r"whose checkpoint frame_000003\.mcack this Simulation was resumed from, and "
                                        r"its newest checkpoint is frame_000004\.mcack: .*remove the checkpoints "
                                        r"after it, or give write_frame another folder"):
        older.write_frame(out)
    assert (out / "stats.csv").read_bytes() == stats and (out / "checkpoints" / "frame_000004.mcack").exists()
    (out / "checkpoints" / "frame_000004.mcack").unlink()
    # Resumed by a relative path, written from another working folder.
    monkeypatch.chdir(tmp_path)
    sim = mca.Simulation.resume("killed", threads=1)
    monkeypatch.chdir(whole)
    assert sim.step == 3 * spf
    assert sim.total_steps == 4 * spf  # (the run's --steps, not the scene's duration)
    # Off the run's clock, refused before the folder is touched.
    sim.advance(spf // 2)
    with pytest.raises(mca.Error, match=rf"goes on frame by frame as mca resume writes it .*: its next frame, 4, is at "
                                        rf"step {4 * spf}, and this Simulation is at step {3 * spf + spf // 2}; "
                                        rf"advance\({spf - spf // 2}\) first"):
        sim.write_frame(out)
    assert (out / "stats.csv").read_bytes() == stats
    sim = mca.Simulation.resume(out, threads=1)
    with pytest.raises(mca.Error, match=r"close_output\(finish=True\): no folder is open"):
        sim.close_output(finish=True)
    assert sim.write_frame(out) == 3  # the checkpoint's own frame: already this state's
    assert sim.write_frame(out / ".") == 3  # (the same folder)
    sim.advance(spf)
    assert sim.write_frame(out) == 4
    sim.advance(1)
    with pytest.raises(mca.Error, match=r"and its last frame is written; this Simulation is at step \d+\. Give "
                                        r"write_frame another folder for frames past the run's end"):
        sim.write_frame(out)
    sim.close_output()
    ended = mca.Simulation.resume(out, threads=1)
    ended.advance(spf)
    assert ended.write_frame(out) == 4
    ended.close_output(finish=True)
    ends = [json.loads((folder / "summary.json").read_text()) for folder in (whole, out)]
    assert ends[1]["status"] == "finished" and ends[1]["state_hash"] == ends[0]["state_hash"]
    assert ends[1]["resumed_from"] == str(out / "checkpoints" / "frame_000003.mcack")
    names = ["stats.csv", "automata.pvd", "projectiles.pvd", "fragments.csv"]
    names += [f"frames/{p.name}" for p in sorted((whole / "frames").iterdir())]
    assert sorted(p.name for p in (out / "frames").iterdir()) == sorted(p.name for p in (whole / "frames").iterdir())
    for name in names:
        assert (out / name).read_bytes() == (whole / name).read_bytes(), name
    # A finished run goes on from its newest checkpoint too, saying that its end is removed.
    again = mca.Simulation.resume(out, threads=1)
    with pytest.warns(UserWarning, match=r"had finished \(its summary\.json says so\): it goes on from its newest "
                                         r"checkpoint \(frame 3\), and its end .* is removed; "
                                         r"close_output\(finish=True\) writes it again"):
        assert again.write_frame(out) == 3
    again.close_output()
    assert not (out / "summary.json").exists()
    # And mca resume takes the folder on from there.
    run_command(mca_binary, "resume", "--quiet", out)
    assert json.loads((out / "summary.json").read_text())["state_hash"] == ends[0]["state_hash"]


def test_a_checkpoint_at_a_runs_short_last_frame_is_its_last_frames(tmp_path, mca_binary):
    """A checkpoint the module saves at the run's last step, where the last frame is shorter than the others,
    is of that frame (it counted one frame too few, and mca resume called the file damaged: a hostile review,
    2026-12-08)."""
    scene = mca.Scene.default()
    scene.output.frame_rate = 5000
    scene_file = tmp_path / "fast.toml"
    scene.save(scene_file)
    spf = mca.Simulation(scene, threads=1).steps_per_frame
    total = 2 * spf + spf // 3
    out = tmp_path / "run"
    run_command(mca_binary, "run", scene_file, "--steps", total, "--checkpoint-every", 1, "--quiet", "--out", out)
    state_hash = json.loads((out / "summary.json").read_text())["state_hash"]
    sim = mca.Simulation.resume(out / "checkpoints" / "frame_000002.mcack", threads=1)
    assert sim.total_steps == total
    sim.advance(total - sim.step)
    sim.checkpoint(out / "checkpoints" / "frame_000003.mcack")  # (in place of the run's own)
    run_command(mca_binary, "resume", "--quiet", out)  # its last frame: the outputs finished again
    assert json.loads((out / "summary.json").read_text())["state_hash"] == state_hash
    again = mca.Simulation.resume(out, threads=1)
    with pytest.warns(UserWarning, match="had finished"):
        assert again.write_frame(out) == 3
    again.close_output(finish=True)
    assert json.loads((out / "summary.json").read_text())["state_hash"] == state_hash


def test_write_frame_writes_nothing_through_links(tmp_path):
    """Neither the folder's write probe nor a subfolder made a link after the first frame is written through
    (a probe link emptied a user's file; frames went on into a linked frames/: the hostile review of
    2026-12-06)."""
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / f".mca_write_probe.{os.getpid()}").symlink_to(precious)
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    assert sim.write_frame(out) == 0
    assert precious.read_text() == "keep me\n"
    elsewhere = tmp_path / "elsewhere"
    (out / "frames").rename(elsewhere)
    (out / "frames").symlink_to(elsewhere)
    before = sorted(p.name for p in elsewhere.iterdir())
    sim.advance(1)
    with pytest.raises(mca.Error, match=r"frames' is a symbolic link .*writes and removes nothing outside its output") \
            as refused:
        sim.write_frame(out)
    assert "--out" not in str(refused.value)
    assert sorted(p.name for p in elsewhere.iterdir()) == before


def test_write_frame_into_a_finished_runs_folder_removes_that_runs_outputs(tmp_path, mca_binary):
    """The first frame removes what an earlier run left, as mca run does: its summary.json, fragments.csv,
    fragment meshes and checkpoints stayed, and the Blender importer took the old run's spacing and pieces
    for the new frames (the hostile review of 2026-12-06)."""
    out = tmp_path / "run"
    scene = mca.Scene.default()
    scene.output.fragments = True
    scene_file = tmp_path / "with_meshes.toml"
    scene.save(scene_file)
    run_command(mca_binary, "run", scene_file, "--steps", 10, "--checkpoint-every", 1, "--quiet", "--out", out)
    for name in ("summary.json", "fragments.csv", "checkpoints"):
        assert (out / name).exists(), name
    assert list((out / "fragments").glob("fragment_*.ply"))
    mine = out / "notes.txt"
    mine.write_text("mine\n")
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    assert sim.write_frame(out) == 0
    assert not (out / "summary.json").exists() and not (out / "fragments.csv").exists()
    assert not list(out.glob("fragments/fragment_*.ply")) and not list(out.glob("checkpoints/*.mcack"))
    # (Its folders left empty go too, as mca run removes them: checkpoints/ stayed.)
    assert not (out / "checkpoints").exists() and not (out / "fragments").exists()
    assert mine.read_text() == "mine\n"


def test_close_output_finish_writes_the_runs_end(tmp_path):
    """A folder of write_frame had no summary.json, fragments.csv or fragment meshes, ever: the Blender importer
    took it for a run still going or killed (the hostile review of 2026-12-07). close_output(finish=True) writes
    them from the state of the last frame written, as mca run does after its last frame."""
    out = tmp_path / "py"
    scene = mca.Scene.default()
    scene.output.fragments = True
    sim = mca.Simulation(scene, threads=1)
    sim.write_frame(out)
    sim.advance(3600)  # the ball through the wall
    sim.write_frame(out)
    sim.advance(1)
    with pytest.raises(mca.Error, match="past the last frame written"):
        sim.close_output(finish=True)
    assert not (out / "summary.json").exists()
    sim.write_frame(out)
    sim.close_output(finish=True)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["state_hash"] == sim.state_hash()
    assert summary["steps"] == 3601 and summary["session_steps"] == 3601
    rows = (out / "fragments.csv").read_text().splitlines()[1:]
    assert len(rows) == summary["fragment_count"] == len(sim.fragments()["id"]) > 1
    meshes = sorted(p.name for p in (out / "fragments").glob("fragment_*.ply"))
    big = [int(r.split(",")[0]) for r in rows if int(r.split(",")[1]) > scene.output.fragment_min_automata]
    assert meshes == [f"fragment_{i:03d}.ply" for i in sorted(big)]
    with pytest.raises(mca.Error, match="no folder is open"):
        sim.close_output(finish=True)
    # A Simulation resumed from a checkpoint names it, and counts its own steps.
    sim.checkpoint(tmp_path / "at3601.mcack")
    resumed = mca.Simulation.resume(tmp_path / "at3601.mcack", threads=1)
    resumed.advance(5)
    resumed.write_frame(tmp_path / "resumed")
    resumed.close_output(finish=True)
    again = json.loads((tmp_path / "resumed" / "summary.json").read_text())
    assert again["resumed_from"] == str(tmp_path / "at3601.mcack")
    assert again["steps"] == 3606 and again["session_steps"] == 5


def test_write_frame_without_vtk_says_it_writes_no_frames(tmp_path):
    scene = mca.Scene.default()
    scene.output.vtk = False
    sim = mca.Simulation(scene, threads=1)
    with pytest.warns(UserWarning, match="output.vtk is false"):
        assert sim.write_frame(tmp_path / "rows") == 0
    assert sim.write_frame(tmp_path / "rows") == 1  # (said once)
    assert len((tmp_path / "rows" / "stats.csv").read_text().splitlines()) == 3
    assert not (tmp_path / "rows" / "frames").exists()


def test_a_folder_write_frame_refuses_leaves_the_one_before(tmp_path):
    """A folder refused (here a file) released the one before, and the next frame there started it afresh,
    its frames and stats removed (a hostile review, 2026-12-06): the one before is kept, and goes on."""
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    out = tmp_path / "out"
    for k in range(3):
        assert sim.write_frame(out) == k
        sim.advance(1)
    (tmp_path / "a_file").write_text("x\n")
    with pytest.raises(mca.Error, match="is not usable") as refused:
        sim.write_frame(tmp_path / "a_file")
    # (The command's flag is not named: the folder is write_frame's.)
    assert "--out" not in str(refused.value) and "output folder for write_frame" in str(refused.value)
    assert sim.write_frame(out) == 3
    assert len(list((out / "frames").glob("automata_*.vtu"))) == 4
    assert (out / "stats.csv").read_text().count("\n") == 5
