#!/usr/bin/env python3
"""Measured restitution of a binary head-on collision: e = -(v1 - v2)_after / (v1 - v2)_before.

Also reports the change of total momentum (N s), which a pair force obeying Newton's third law keeps at 0.
"""
import csv

with open("thermo.csv", newline="") as handle:
    rows = list(csv.DictReader(handle))
first, last = rows[0], rows[-1]
approach = float(first["vx[1]"]) - float(first["vx[2]"])
separation = float(last["vx[1]"]) - float(last["vx[2]"])
momentum_change = float(last["momentum_x"]) - float(first["momentum_x"])
with open("restitution.txt", "w") as out:
    out.write("e momentum_change\n%.12g %.12g\n" % (-separation / approach, momentum_change))
