#!/usr/bin/env python3
"""Apex heights of an elastic sphere bouncing on a plane: with e = 1 the energy must not drift.

Writes bounce.txt: the number of bounces, the first and the last apex height (m), and their ratio.
An apex is a local maximum of z between two contacts; the thermo rows must be dense enough (every 20 steps).
"""
import csv

with open("thermo.csv", newline="") as handle:
    z = [float(row["z[1]"]) for row in csv.DictReader(handle)]
apexes = [z[i] for i in range(1, len(z) - 1) if z[i - 1] < z[i] >= z[i + 1]]
if len(apexes) < 2:
    raise SystemExit(f"bounce.py: only {len(apexes)} apex found in thermo.csv")
with open("bounce.txt", "w") as out:
    out.write("bounces first_apex last_apex ratio\n%d %.12g %.12g %.12g\n"
              % (len(apexes), apexes[0], apexes[-1], apexes[-1] / z[0]))
