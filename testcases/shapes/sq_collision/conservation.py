#!/usr/bin/env python3
"""Two ellipsoids of equal mass (scene.json) collide without damping or friction: from thermo.csv, per row the
changes since the first row of the energy ke + rke (relative; meaningful once the contact is over), of the
momentum (relative to its size m |v1(0)|) and of the angular momentum about the origin, sum of L_body + m x v
(relative to its first value). Writes post/conservation.csv (time, energy, momentum, angular_momentum,
speed_change: how much body 1's velocity changed, to show that they met)."""
import csv
import math
from pathlib import Path

import numpy as np

RHO = 2500.0
A, B, C = 0.01, 0.006, 0.004
mass = RHO * 4.0 / 3.0 * math.pi * A * B * C

with open("thermo.csv") as handle:
    rows = list(csv.reader(handle))
col = {name: np.array([float(r[k]) for r in rows[1:]]) for k, name in enumerate(rows[0])}
energy = col["ke"] + col["rke"]
momentum = np.zeros((len(energy), 3))
angular = np.zeros((len(energy), 3))
for k in (1, 2):
    x = np.stack([col[f"sq_{a}[{k}]"] for a in "xyz"], 1)
    v = np.stack([col[f"sq_v{a}[{k}]"] for a in "xyz"], 1)
    momentum += mass * v
    angular += np.stack([col[f"sq_l{a}[{k}]"] for a in "xyz"], 1) + mass * np.cross(x, v)
v1 = np.stack([col[f"sq_v{a}[1]"] for a in "xyz"], 1)
with open(Path("post") / "conservation.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["time", "energy", "momentum", "angular_momentum", "speed_change"])
    for k in range(len(energy)):
        out.writerow([col["time"][k], repr(float(energy[k] / energy[0] - 1.0)),
                      repr(float(np.linalg.norm(momentum[k] - momentum[0]) / (mass * np.linalg.norm(v1[0])))),
                      repr(float(np.linalg.norm(angular[k] - angular[0]) / np.linalg.norm(angular[0]))),
                      repr(float(np.linalg.norm(v1[k] - v1[0])))])
