#!/usr/bin/env python3
"""Error of a sphere oscillating on a linear (Hooke, e = 1) wall spring under gravity, against the exact solution.

Hooke stiffness (LIGGGHTS normal_model_hooke.h, physics.md), wall: R* = r, m* = m, 1/Y* = 2 (1 - nu^2) / Y:
    kn = 16/15 sqrt(R*) Y* (15 m* V^2 / (16 sqrt(R*) Y*))^(1/5)
The sphere never leaves the wall, so z(t) = z_eq + (z0 - z_eq) cos(w t), w = sqrt(kn / m), z_eq = r - m g / kn.
Writes oscillator.txt: the time (s), the exact and computed height (m) and the absolute error (m).
"""
import csv
import math

RADIUS, DENSITY, YOUNG, POISSON, V_CHAR, G = 0.005, 2500.0, 5e6, 0.3, 1.0, 9.81

mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
y_eff = YOUNG / (2.0 * (1.0 - POISSON**2))
kn = 16.0 / 15.0 * math.sqrt(RADIUS) * y_eff * (15.0 * mass * V_CHAR**2 / (16.0 * math.sqrt(RADIUS) * y_eff)) ** 0.2
omega = math.sqrt(kn / mass)
z_eq = RADIUS - mass * G / kn

with open("thermo.csv", newline="") as handle:
    rows = list(csv.DictReader(handle))
z0 = float(rows[0]["z[1]"])
t = float(rows[-1]["time"])
z_exact = z_eq + (z0 - z_eq) * math.cos(omega * t)
z = float(rows[-1]["z[1]"])
with open("oscillator.txt", "w") as out:
    out.write("time z_exact z error\n%.12g %.15g %.15g %.6g\n" % (t, z_exact, z, abs(z - z_exact)))
