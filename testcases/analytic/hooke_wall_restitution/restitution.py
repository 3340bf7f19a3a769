#!/usr/bin/env python3
"""Measured coefficient of restitution of a single wall impact without gravity: e = -vz(end) / vz(start).

Reads thermo.csv of the run folder, writes restitution.txt (a header line, then the numbers).
"""
import csv

with open("thermo.csv", newline="") as handle:
    rows = list(csv.DictReader(handle))
e = -float(rows[-1]["vz[1]"]) / float(rows[0]["vz[1]"])
with open("restitution.txt", "w") as out:
    out.write("e\n%.12g\n" % e)
