#!/usr/bin/env python3
"""The superquadrics' series (post/superquadrics.csv) against the spheres' (post/spheres.csv, copied from the run
`spheres`): per row the largest difference of each position, velocity and angular velocity, relative to the
largest value of that column over the run. Writes post/compare.csv (time, difference)."""
import csv
from pathlib import Path


def read(path):
    with open(path) as handle:
        rows = list(csv.reader(handle))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


spheres_head, spheres = read("post/spheres.csv")
sq_head, bodies = read("post/superquadrics.csv")
assert [h.removeprefix("sq_") for h in sq_head] == spheres_head and len(spheres) == len(bodies) > 10
scale = [max(abs(row[c]) for row in spheres) or 1.0 for c in range(len(spheres_head))]
with open(Path("post") / "compare.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["time", "difference", "moved"])
    for a, b in zip(spheres, bodies):
        diff = max(abs(a[c] - b[c]) / scale[c] for c in range(1, len(a)))
        # how far the upper sphere was pushed sideways (it lands on the lower one): the pair met
        moved = abs(a[spheres_head.index("x[2]")] - 0.002)
        out.writerow([a[0], repr(diff), repr(moved)])
