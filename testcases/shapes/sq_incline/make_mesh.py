#!/usr/bin/env python3
"""Write incline35.stl (ASCII): the square x, y in [-100, 100] mm at z = 0 as 20 x 20 squares of 10 mm, each split
into two triangles, turned by 35 degrees about y so that its normal is (-sin 35, 0, cos 35), the normal of the
plane wall of the run theta35 (mesh.json: the same scene on this mesh).

    python make_mesh.py              # rewrites incline35.stl (committed)
"""
import math
from pathlib import Path

THETA = math.radians(35.0)
CELLS = 20
HALF = 0.1  # m


def turned(p):
    """Rotation by THETA about y: (x, y, z) -> (x cos + z sin, y, -x sin + z cos)."""
    x, y, z = p
    return (x * math.cos(THETA) + z * math.sin(THETA), y, -x * math.sin(THETA) + z * math.cos(THETA))


def grid(half, cells):
    s = [-half + 2 * half * k / cells for k in range(cells + 1)]
    for a in range(cells):
        for b in range(cells):
            p = [(s[a], s[b], 0.0), (s[a + 1], s[b], 0.0), (s[a + 1], s[b + 1], 0.0), (s[a], s[b + 1], 0.0)]
            yield p[0], p[1], p[2]
            yield p[0], p[2], p[3]


if __name__ == "__main__":
    lines = ["solid incline"]
    for t in grid(HALF, CELLS):
        lines += [" facet normal 0 0 0", "  outer loop"] + [
            "   vertex {!r} {!r} {!r}".format(*turned(v)) for v in t] + ["  endloop", " endfacet"]
    (Path(__file__).parent / "incline35.stl").write_text("\n".join(lines + ["endsolid incline", ""]))
