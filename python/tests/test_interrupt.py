"""Ctrl-C during a long advance raises KeyboardInterrupt within a fraction of a second, and leaves a
simulation that can go on."""
import contextlib
import os
import signal
import subprocess
import sys
import textwrap
import time

SCRIPT = textwrap.dedent(
    """
    import sys, time
    import mca
    sim = mca.Simulation(mca.Scene.default(), threads=2)
    sim.advance(10)
    print("advancing", flush=True)
    try:
        sim.advance(10**9)  # hours
    except KeyboardInterrupt:
        t = time.monotonic()  # before sim.step, which waits for the slice in flight
        print(f"interrupted {t:.6f} step {sim.step}", flush=True)
        before = sim.step
        sim.advance(5)  # the state is whole: it goes on
        assert sim.step == before + 5
        print("went on", flush=True)
        sys.exit(0)
    sys.exit(3)
    """
)


@contextlib.contextmanager
def running(script, *args):
    """The script in a Python of its own, its output piped; killed if it still runs at the end."""
    p = subprocess.Popen([sys.executable, "-c", script, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=os.environ.copy())
    try:
        yield p
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()


def interrupt(p, after):
    """SIGINT to p `after` seconds from now: when it was sent, and the words of p's next line."""
    time.sleep(after)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    return sent, p.stdout.readline().split()


def test_ctrl_c_raises_keyboard_interrupt_quickly():
    with running(SCRIPT) as p:
        assert p.stdout.readline().strip() == "advancing", p.stderr.read()
        sent, line = interrupt(p, 1.0)  # well inside the long advance
        printed = time.monotonic()
        assert line[:1] == ["interrupted"], p.stderr.read()
        latency = float(line[1]) - sent
        # sim.step waited for the slice in flight (about 2 s of steps; a loaded machine stretches it).
        assert printed - sent < 10, f"the slice in flight ended {printed - sent:.1f} s after SIGINT"
        assert int(line[3]) > 10
        assert p.stdout.readline().strip() == "went on"
        assert p.wait(timeout=30) == 0
        # The waiting thread checks for signals every 50 ms; a loaded machine may delay it a little.
        assert latency < 0.3, f"KeyboardInterrupt came {latency:.3f} s after SIGINT"


RACE = textwrap.dedent(
    """
    import _thread, threading, time
    import mca
    sim = mca.Simulation(mca.Scene.default(), threads=1)
    sim.advance(10)
    for trial in range(3):
        threading.Thread(target=lambda: (time.sleep(0.3), _thread.interrupt_main())).start()
        try:
            sim.advance(10**6)
        except KeyboardInterrupt:
            pass
        got = []
        def read():
            try:
                got.append(sim.positions().shape[0])
            except mca.Error as e:
                got.append("advancing" if "advancing" in str(e) else str(e))
        reader = threading.Thread(target=read)
        reader.start()
        sim.advance(5)
        reader.join()
        print("trial", trial, got, flush=True)
    print("done", flush=True)
    """
)


def test_a_read_racing_an_advance_after_ctrl_c_does_not_hang():
    """After a Ctrl-C leaves a slice running, a read in one thread and an advance in another both waited for
    it by joining the same thread, and the read hung for good (3 of 3 tries: the hostile review of
    2026-12-06). Now one waits for the slice and the other finds it gone; the read gets the positions or
    mca.Error (the simulation is advancing), never a hang."""
    p = subprocess.run([sys.executable, "-c", RACE], capture_output=True, text=True, env=os.environ.copy(),
                       timeout=180)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[-1] == "done", p.stdout + p.stderr
    trials = [l for l in lines if l.startswith("trial")]
    assert len(trials) == 3
    for line in trials:
        assert line.endswith("[4800]") or line.endswith("['advancing']"), line


def test_an_exit_while_a_daemon_thread_advances_is_clean(tmp_path):
    """The interpreter's exit ends a daemon thread that is in advance as it takes the GIL back; that ending,
    a forced unwind, passed through a noexcept destructor and aborted the process ("terminate called without
    an active exception", exit code 134, in every try; a hostile review, 2026-12-06)."""
    script = (
        "import threading, time\n"
        "import mca\n"
        "sim = mca.Simulation(mca.Scene.default(), threads=1)\n"
        "threading.Thread(target=lambda: sim.advance(10**7), daemon=True).start()\n"
        "time.sleep(float(__import__('sys').argv[1]))\n"
        "print('main exits', flush=True)\n")
    for wait in ("0.1", "0.4", "1"):
        r = subprocess.run([sys.executable, "-c", script, wait], capture_output=True, text=True, timeout=120,
                           env=os.environ.copy(), cwd=tmp_path)
        assert r.returncode == 0 and "terminate" not in r.stderr, (wait, r.returncode, r.stderr[-1000:])
        assert r.stdout == "main exits\n"


FINISH = textwrap.dedent(
    """
    import json, pathlib, sys, time
    import mca
    out = pathlib.Path(sys.argv[1])
    # One block of 64,000 automata: its fragment mesh takes seconds.
    scene = mca.Scene.from_toml('[solver]\\nspacing = 0.05\\ngravity = [0, 0, 0]\\n[output]\\nfragments = true\\n'
                                '[[object]]\\nname = "block"\\nshape = "box"\\nsize = [2.0, 2.0, 2.0]\\n')
    sim = mca.Simulation(scene, threads=1)
    sim.write_frame(out)
    def reads(done, total):
        try:
            sim.step
        except mca.Error as e:
            print("refused:", e, flush=True)
            raise
    try:
        sim.close_output(finish=True, progress=reads)
    except mca.Error:
        pass
    print("meshing", flush=True)
    try:
        sim.close_output(finish=True)
    except KeyboardInterrupt:
        t = time.monotonic()
        print(f"interrupted {t:.6f}", flush=True)
        assert not (out / "summary.json").exists()
        seen = []
        sim.close_output(finish=True, progress=lambda done, total: seen.append((done, total)))
        assert seen == [(1, 1)], seen
        assert json.loads((out / "summary.json").read_text())["status"] == "finished"
        assert (out / "fragments" / "fragment_000.ply").stat().st_size > 0
        print("finished", flush=True)
        sys.exit(0)
    sys.exit(3)
    """
)


def test_ctrl_c_ends_the_fragment_meshes_of_close_output_quickly(tmp_path):
    """close_output(finish=True) made the fragment meshes holding the GIL, deaf to Ctrl-C for as long as they
    took (a shattered object's, a minute). They are made on a thread of their own now: KeyboardInterrupt
    comes within the piece being meshed, the folder is left without summary.json, and close_output(finish=True)
    again writes the end whole. The progress callback cannot read the simulation meanwhile (mca.Error)."""
    with running(FINISH, str(tmp_path / "out")) as p:
        line = p.stdout.readline()
        assert line.startswith("refused: the simulation is writing its run's end"), line + p.stderr.read()
        assert p.stdout.readline().strip() == "meshing", p.stderr.read()
        sent, line = interrupt(p, 1.0)  # well inside the meshing (about 5 s on one thread)
        assert line[:1] == ["interrupted"], p.stderr.read()
        latency = float(line[1]) - sent
        assert p.stdout.readline().strip() == "finished", p.stderr.read()
        assert p.wait(timeout=60) == 0
        # The meshing polls for the stop every slab of voxels; a loaded machine may delay it a little.
        assert latency < 0.5, f"KeyboardInterrupt came {latency:.3f} s after SIGINT"
