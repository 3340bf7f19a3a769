#!/usr/bin/env python3
"""The ellipsoid on the incline (scene.json, thermo.csv): position s and velocity v along the incline,
downhill; after t = 0.2 s (landing over) a straight-line fit of v(t) gives the mean acceleration, to compare with
g (sin theta - mu cos theta) when tan theta > mu, and with 0 below. Writes post/incline.csv: acceleration,
analytic (0 when it should stick), error (acceleration - analytic, m/s^2), drift (largest distance from the
mean position after 0.2 s, m). The incline's angle from the first row: the body starts on the plane's normal
through the origin; mu = 0.5 as in scene.json."""
import csv
import math
from pathlib import Path

import numpy as np

MU = 0.5
with open("thermo.csv") as handle:
    rows = list(csv.reader(handle))
head = rows[0]
data = np.array([[float(v) for v in row] for row in rows[1:]])
col = {name: data[:, k] for k, name in enumerate(head)}
theta = math.atan2(-col["sq_x[1]"][0], col["sq_z[1]"][0])
mu = MU
down = (-math.cos(theta), -math.sin(theta))
s = col["sq_x[1]"] * down[0] + col["sq_z[1]"] * down[1]
v = col["sq_vx[1]"] * down[0] + col["sq_vz[1]"] * down[1]
late = col["time"] >= 0.2
acceleration = float(np.polyfit(col["time"][late], v[late], 1)[0])
slides = math.tan(theta) > mu
analytic = 9.81 * (math.sin(theta) - mu * math.cos(theta)) if slides else 0.0
drift = float(np.abs(s[late] - s[late].mean()).max())
with open(Path("post") / "incline.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["acceleration", "analytic", "error", "drift"])
    out.writerow([repr(acceleration), repr(analytic), repr(acceleration - analytic), repr(drift)])
