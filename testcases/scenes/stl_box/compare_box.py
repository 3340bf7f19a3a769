#!/usr/bin/env python3
"""Compare the STL box's trajectory with the plane box's (post/ of the run this one depends on).

Reads post/trajectory_planes.csv (copied in from the `planes` run) and post/trajectory_mesh.csv (this run),
both `step,time,x[1],y[1],z[1],...` every 100 steps. Writes box_agreement.txt, one row:
rows (printed rows compared), spheres, max_abs_diff (largest |x_mesh - x_planes| over every coordinate and
row, m) and max_rel_diff (the same over the box's height 2 A = 0.0625 m). Rows must match step for step.
"""
import csv
import sys

BOX = 0.0625  # m


def read(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


head_p, planes = read("post/trajectory_planes.csv")
head_m, mesh = read("post/trajectory_mesh.csv")
if head_p != head_m:
    sys.exit(f"columns differ: {head_p} vs {head_m}")
if [r[0] for r in planes] != [r[0] for r in mesh]:
    sys.exit(f"steps differ: {len(planes)} rows of the plane box, {len(mesh)} of the STL box")
worst = max(abs(a - b) for rp, rm in zip(planes, mesh) for a, b in zip(rp[2:], rm[2:]))
with open("box_agreement.txt", "w") as out:
    out.write("rows spheres max_abs_diff max_rel_diff\n")
    out.write(f"{len(planes)} {(len(head_p) - 2) // 3} {worst!r} {worst / BOX!r}\n")
