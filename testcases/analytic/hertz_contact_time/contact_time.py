#!/usr/bin/env python3
"""Duration of an elastic Hertz collision, from the thermo rows (one per step) that count a contact.

Writes contact.txt: contact_time (s) and the ratio of rebound to impact speed (1 for e = 1).
"""
import csv

with open("thermo.csv", newline="") as handle:
    rows = list(csv.DictReader(handle))
dt = float(rows[1]["time"]) - float(rows[0]["time"])
in_contact = sum(1 for row in rows[1:] if float(row["contacts"]) > 0)
speed_ratio = -float(rows[-1]["vx[1]"]) / float(rows[0]["vx[1]"])
with open("contact.txt", "w") as out:
    out.write("contact_time speed_ratio\n%.12g %.12g\n" % (in_contact * dt, speed_ratio))
