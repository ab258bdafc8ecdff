#!/usr/bin/env python3
"""A parameter sweep: the default wall struck at three ball speeds.

    /usr/bin/python3 examples/speed_sweep.py [DURATION_S]

prints, per speed, the broken links, the fragments and the heaviest fragment's share of the mass.
"""
import sys

import mca

try:
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 0.02  # simulated seconds
except ValueError:
    duration = float("nan")
if not 0 < duration < float("inf"):
    sys.exit(f"speed_sweep.py: the duration {sys.argv[1]!r} is not a positive number of simulated seconds; "
             "e.g. 0.02")
base = mca.Scene.default()  # scenes/wall_ball.toml: the ball flies along +y at 30 m/s
for speed in (30.0, 60.0, 120.0):
    scene = base.copy()
    scene.projectiles[0].velocity = (0.0, speed, 0.0)
    sim = mca.Simulation(scene)
    sim.advance_to(duration)
    f = sim.fragments()
    print(f"{speed:5.0f} m/s: {sim.broken_links()['total']} broken links, {len(f['id'])} fragments, "
          f"heaviest {f['mass'][0] / f['mass'].sum():.0%} of the mass")
