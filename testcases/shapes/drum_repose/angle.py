#!/usr/bin/env python3
"""Dynamic angle of repose of the rotating drum in either code: angle.txt, drum.csv, angle_series.csv.

The measurement is harness/execution/repose.py (shared with testcases/scenes/drum); this scene's time step
(every script's dt, LIGGGHTS prints no time column) and the diameter of the spheres and of the dumbbells'
members go with it. The steady part starts at t = 1 s (the bed forms and first reaches its angle by 0.6 s);
the windows of drum.csv are 0.5 s, about one avalanche period at omega = 2 rad/s, from t = 0.5 s: the
dumbbells are inserted at random positions until 0.2 s, each code and seed with its own, so the first half
second is a fall no two runs share (the engine's angle in it spreads over 7 degrees between seeds).
"""
from harness.execution import repose

print(repose.report(repose.measure(".", timestep=2e-5, diameter=0.004, t_steady=1.0, window=0.5, window_start=0.5)))
