#!/usr/bin/env python3
"""The Python module's overhead over the command for advance on wall_357k (docs/benchmarks.md, "Python").

    /usr/bin/python3 bench/python_overhead.py [--pairs 5] [--steps 100] [--threads 2]

Each pair runs `mca bench wall_357k --json --repeats 1 --steps S` and then the same in a fresh Python
process: the same scene built through mca.Scene (app/bench.cpp's wall_scene, checked by its automata and
link counts), the same 150 warm-up steps, then S steps timed around sim.advance(S). Prints the two wall
times of each pair, their ratio, and the median ratio.
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


def child(steps, threads):
    import mca

    sim = mca.Simulation(wall_357k(), threads=threads)
    assert (sim.automata, sim.link_count) == (357035, 1053834), (sim.automata, sim.link_count)
    sim.advance(150)  # the command's warm-up: the ball is in the wall
    t0 = time.perf_counter()
    sim.advance(steps)
    wall = time.perf_counter() - t0
    print(json.dumps({"wall_seconds": wall, "broken": sim.broken_links()["total"]}))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--mca", default=str(SOURCE / "build" / "release" / "mca"))
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(a.steps, a.threads)
    ratios = []
    for k in range(a.pairs):
        r = subprocess.run([a.mca, "bench", "wall_357k", "--json", "--repeats", "1", "--steps", str(a.steps),
                            "--threads", str(a.threads)], capture_output=True, text=True, check=True)
        command = json.loads(r.stdout)[0]["median_wall_seconds"]
        r = subprocess.run([sys.executable, __file__, "--child", "--steps", str(a.steps), "--threads",
                            str(a.threads)], capture_output=True, text=True, check=True, env=os.environ.copy())
        module = json.loads(r.stdout)["wall_seconds"]
        ratios.append(module / command)
        print(f"pair {k + 1}: command {command:.3f} s, module {module:.3f} s, ratio {module / command:.4f}", flush=True)
    print(f"median ratio module / command over {a.pairs} pairs of {a.steps} steps on {a.threads} threads: "
          f"{statistics.median(ratios):.4f}")


if __name__ == "__main__":
    main()
