#!/usr/bin/env python3
"""Write meshes/floor.stl (ASCII): the square x, y in [-50, 50] mm at z = 0 as 20 x 20 squares of 5 mm, each split
into two triangles along a diagonal (800 triangles, smaller than the bodies thrown on it, so that their
contacts cross faces and the flat edges between them). z = 0 is exact in float32, so the mesh lies exactly on
the plane z = 0 of plane.json.

    python make_meshes.py            # rewrites meshes/floor.stl (committed)
"""
from pathlib import Path

CELLS = 20
HALF = 0.05  # m


def grid(half, cells):
    s = [-half + 2 * half * k / cells for k in range(cells + 1)]
    for a in range(cells):
        for b in range(cells):
            p = [(s[a], s[b], 0.0), (s[a + 1], s[b], 0.0), (s[a + 1], s[b + 1], 0.0), (s[a], s[b + 1], 0.0)]
            yield p[0], p[1], p[2]
            yield p[0], p[2], p[3]


def write_stl(path, triangles):
    lines = ["solid floor"]
    for t in triangles:
        lines += [" facet normal 0 0 1", "  outer loop"] + [f"   vertex {v[0]!r} {v[1]!r} {v[2]!r}" for v in t] + \
                 ["  endloop", " endfacet"]
    Path(path).write_text("\n".join(lines + ["endsolid floor", ""]))


if __name__ == "__main__":
    here = Path(__file__).parent
    write_stl(here / "meshes" / "floor.stl", grid(HALF, CELLS))
