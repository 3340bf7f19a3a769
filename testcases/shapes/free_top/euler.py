#!/usr/bin/env python3
"""The exact torque-free motion of the asymmetric top of scene.json against the engine's thermo.csv.

Moments of inertia of the four separate spheres about the centre (parallel-axis theorem; the engine's
template integration is exact for spheres that do not overlap), density 2500 kg/m^3. The body-frame angular
velocity of a free top with I1 < I2 < I3 started at (w10, 0, w30), L^2 > 2 E I2, in Jacobi elliptic
functions (Landau & Lifshitz, Mechanics, section 37):
  w1 = A1 cn(lambda t, m), w2 = A2 sn(lambda t, m), w3 = A3 dn(lambda t, m).
Body axes are the principal axes up to sign: the signs of the first row give them (Euler's equations are
invariant when two components change sign). Writes post/euler.csv (t, the three errors, the relative change
of |L| and of each component of L).
"""
import csv
import math
from pathlib import Path

import numpy as np
from scipy.special import ellipj

RHO = 2500.0
SPHERES = [(0.03, 0, 0, 0.01), (-0.03, 0, 0, 0.01), (0, 0.02, 0, 0.008), (0, -0.02, 0, 0.008)]

inertia = np.zeros((3, 3))
for x, y, z, r in SPHERES:
    m = RHO * 4 / 3 * math.pi * r ** 3
    d = np.array([x, y, z])
    inertia += 0.4 * m * r * r * np.eye(3) + m * (d @ d * np.eye(3) - np.outer(d, d))
i1, i2, i3 = np.sort(np.linalg.eigvalsh(inertia))

with open("thermo.csv") as handle:
    rows = list(csv.DictReader(handle))
dt = float(rows[1]["time"]) / float(rows[1]["step"])
t = np.array([float(r["time"]) for r in rows])
w = np.array([[float(r[f"body_w{k}[1]"]) for k in (1, 2, 3)] for r in rows])
angmom = np.array([[float(r[f"body_l{a}[1]"]) for a in "xyz"] for r in rows])
s1, s3 = math.copysign(1.0, w[0, 0]), math.copysign(1.0, w[0, 2])
w10, w30 = abs(w[0, 0]), abs(w[0, 2])
l2 = (i1 * w10) ** 2 + (i3 * w30) ** 2
e2 = i1 * w10 ** 2 + i3 * w30 ** 2
assert l2 > e2 * i2, "the top must turn about its axis of largest moment"
a1 = math.sqrt((e2 * i3 - l2) / (i1 * (i3 - i1)))
a2 = math.sqrt((e2 * i3 - l2) / (i2 * (i3 - i2)))
a3 = math.sqrt((l2 - e2 * i1) / (i3 * (i3 - i1)))
rate = math.sqrt((i3 - i2) * (l2 - e2 * i1) / (i1 * i2 * i3))
m = (i2 - i1) * (e2 * i3 - l2) / ((i3 - i2) * (l2 - e2 * i1))
sn, cn, dn, _ = ellipj(rate * t, m)
exact = np.stack([s1 * a1 * cn, s1 * s3 * a2 * sn, s3 * a3 * dn], axis=1)
error = (w - exact) / w30
l0 = np.linalg.norm(angmom[0])
drift = np.abs(angmom - angmom[0]).max(axis=1) / l0
Path("post").mkdir(exist_ok=True)
with open("post/euler.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["t", "error_w1", "error_w2", "error_w3", "l_drift", "w1_exact"])
    for k in range(len(t)):
        out.writerow([repr(float(t[k])), *(repr(float(e)) for e in error[k]), repr(float(drift[k])),
                      repr(float(exact[k, 0]))])
