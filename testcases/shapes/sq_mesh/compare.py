#!/usr/bin/env python3
"""The bodies on the mesh floor (post/mesh.csv) against the same bodies on the plane z = 0 (post/plane.csv, copied
from the run `plane`): per row the largest difference of any position, velocity or angular momentum, relative to
the largest value of that column over the run; and how far the bodies slid (m), over how many 5 mm triangles.
Writes post/compare.csv (time, difference, slid)."""
import csv
from pathlib import Path


def read(path):
    with open(path) as handle:
        rows = list(csv.reader(handle))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


plane_head, plane = read("post/plane.csv")
mesh_head, mesh = read("post/mesh.csv")
assert plane_head == mesh_head and len(plane) == len(mesh) > 10
scale = [max(abs(row[c]) for row in plane) or 1.0 for c in range(len(plane_head))]
x1, x2 = plane_head.index("sq_x[1]"), plane_head.index("sq_x[2]")
with open(Path("post") / "compare.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["time", "difference", "slid"])
    for a, b in zip(plane, mesh):
        diff = max(abs(a[c] - b[c]) / scale[c] for c in range(1, len(a)))
        slid = min(abs(a[x1] - plane[0][x1]), abs(a[x2] - plane[0][x2]))
        out.writerow([a[0], repr(diff), repr(slid)])
