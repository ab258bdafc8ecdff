#!/usr/bin/env python3
"""The Python module's overhead over the command for advance on wall_357k (docs/benchmarks.md, "Python").

    /usr/bin/python3 bench/python_overhead.py [--pairs 5] [--steps 100] [--threads 2] [--against-command]

By default, in one process (so that the load of a shared machine falls on both alike): the scene built
through mca.Scene (app/bench.cpp's wall_scene, checked by its automata and link counts), 150 warm-up steps,
then Simulation._bench_advance: from that snapshot, uploaded again before each timed run as `mca bench`
does, sim.advance(S) as Python calls it (the stepping thread, its slices, the waits and the signal checks)
and one Engine::advance(S) as `mca bench` times it, in turn.

With --against-command, each pair runs `mca bench wall_357k --json --repeats 1 --steps S` and then the same in a fresh Python
process: the same scene built through mca.Scene (app/bench.cpp's wall_scene, checked by its automata and
link counts), the same 150 warm-up steps, the state uploaded again as the command's snapshot is (through
sim.checkpoint and Simulation.resume; --start continue skips that), then S steps timed around
sim.advance(S). Prints the two wall times of each pair, their ratio, and the median ratio.
"""
import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import time

SOURCE = pathlib.Path(__file__).resolve().parents[1]


def wall_357k():
    """app/bench.cpp's wall_scene("wall_357k", 101, 35, 101, 1, 0.02), written with the module."""
    import mca

    nx, ny, nz, d = 101, 35, 101, 0.02
    s = mca.Scene("wall_357k")
    s.solver.spacing = d
    s.heterogeneity.preset = "medium"
    s.ground.enabled = True
    wx, wy, wz = nx * d, ny * d, nz * d
    ball = max(3 * d, 0.1 * min(wx, wz))
    s.add_object(name="wall0", size=(wx, wy, wz), position=(0.0, 0.0, 0.5 * wz))
    s.add_projectile(name="ball0", radius=ball, position=(0.0, -0.5 * wy - ball - 0.05 * d, 0.5 * wz),
                     velocity=(0.0, 60.0, 0.0))
    s.output.duration = 0.01
    return s


def child(steps, threads, start):
    import tempfile

    import mca

    sim = mca.Simulation(wall_357k(), threads=threads)
    assert (sim.automata, sim.link_count) == (357035, 1053834), (sim.automata, sim.link_count)
    sim.advance(150)  # the command's warm-up: the ball is in the wall
    if start == "resume":
        # As `mca bench`, which uploads its snapshot before each timed run: the state goes through a
        # checkpoint into a new Simulation, whose backend is given it by upload.
        with tempfile.TemporaryDirectory() as d:
            sim.checkpoint(os.path.join(d, "warm.mcack"))
            del sim
            sim = mca.Simulation.resume(os.path.join(d, "warm.mcack"), threads=threads)
    t0 = time.perf_counter()
    sim.advance(steps)
    wall = time.perf_counter() - t0
    print(json.dumps({"wall_seconds": wall, "broken": sim.broken_links()["total"]}))


def in_process(steps, pairs, threads):
    import mca

    sim = mca.Simulation(wall_357k(), threads=threads)
    assert (sim.automata, sim.link_count) == (357035, 1053834), (sim.automata, sim.link_count)
    sim.advance(150)  # the command's warm-up: the ball is in the wall
    walls, cpus = [], []
    for k, (module, command, module_cpu, command_cpu) in enumerate(sim._bench_advance(steps, pairs)):
        walls.append(module / command)
        cpus.append(module_cpu / command_cpu)
        print(f"pair {k + 1}: wall Engine::advance {command:.3f} s, module {module:.3f} s, ratio {walls[-1]:.4f}; "
              f"CPU {command_cpu:.3f} s, {module_cpu:.3f} s, ratio {cpus[-1]:.4f}", flush=True)
    print(f"median ratio module / Engine::advance over {pairs} pairs of {steps} steps on {threads} threads, in one "
          f"process: wall {statistics.median(walls):.4f}, CPU time {statistics.median(cpus):.4f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--mca", default=str(SOURCE / "build" / "release" / "mca"))
    ap.add_argument("--start", choices=["resume", "continue"], default="resume",
                    help="resume: the timed steps start from an uploaded snapshot, as mca bench's (default); "
                         "continue: right after the warm-up, in the same Simulation")
    ap.add_argument("--against-command", action="store_true",
                    help="pairs of processes, the mca command and a Python one, instead of both in one process")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(a.steps, a.threads, a.start)
    if not a.against_command:
        return in_process(a.steps, a.pairs, a.threads)
    ratios = []
    for k in range(a.pairs):
        r = subprocess.run([a.mca, "bench", "wall_357k", "--json", "--repeats", "1", "--steps", str(a.steps),
                            "--threads", str(a.threads)], capture_output=True, text=True, check=True)
        command = json.loads(r.stdout)[0]["median_wall_seconds"]
        r = subprocess.run([sys.executable, __file__, "--child", "--steps", str(a.steps), "--threads",
                            str(a.threads), "--start", a.start], capture_output=True, text=True, check=True,
                           env=os.environ.copy())
        module = json.loads(r.stdout)["wall_seconds"]
        ratios.append(module / command)
        print(f"pair {k + 1}: command {command:.3f} s, module {module:.3f} s, ratio {module / command:.4f}", flush=True)
    print(f"median ratio module / command ({a.start}) over {a.pairs} pairs of {a.steps} steps on {a.threads} threads: "
          f"{statistics.median(ratios):.4f}")


if __name__ == "__main__":
    main()
