#!/usr/bin/env python3
"""Write incline35.stl (ASCII): the rectangle x in [-600, 50] mm, y in [-20, 20] mm at z = 0 as 65 x 4 squares of
10 mm, each split into two triangles (520; the body slides about 0.5 m downhill, towards -x, in 0.8 s), turned by 35 degrees about y so that its normal is (-sin 35, 0, cos 35), the normal of the
plane wall of the run theta35 (mesh.json: the same scene on this mesh).

    python make_mesh.py              # rewrites incline35.stl (committed)
"""
import math
from pathlib import Path

THETA = math.radians(35.0)
X0, X1, Y0, Y1 = -0.6, 0.05, -0.02, 0.02  # m
CELL = 0.01  # m


def turned(p):
    """Rotation by -THETA about y: (x, y, z) -> (x cos - z sin, y, x sin + z cos); z -> the normal, -x -> downhill."""
    x, y, z = p
    return (x * math.cos(THETA) - z * math.sin(THETA), y, x * math.sin(THETA) + z * math.cos(THETA))


def grid():
    nx, ny = round((X1 - X0) / CELL), round((Y1 - Y0) / CELL)
    xs = [X0 + (X1 - X0) * k / nx for k in range(nx + 1)]
    ys = [Y0 + (Y1 - Y0) * k / ny for k in range(ny + 1)]
    for a in range(nx):
        for b in range(ny):
            p = [(xs[a], ys[b], 0.0), (xs[a + 1], ys[b], 0.0), (xs[a + 1], ys[b + 1], 0.0), (xs[a], ys[b + 1], 0.0)]
            yield p[0], p[1], p[2]
            yield p[0], p[2], p[3]


if __name__ == "__main__":
    lines = ["solid incline"]
    for t in grid():
        lines += [" facet normal 0 0 0", "  outer loop"] + [
            "   vertex {!r} {!r} {!r}".format(*turned(v)) for v in t] + ["  endloop", " endfacet"]
    (Path(__file__).parent / "incline35.stl").write_text("\n".join(lines + ["endsolid incline", ""]))
