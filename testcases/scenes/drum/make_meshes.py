#!/usr/bin/env python3
"""Write the rotating drum's STL files (ASCII, metres) into meshes/: the same geometry for both codes.

The drum is a closed cylinder along the y axis, centred on the origin: radius R = 0.04 m, length L = 0.02 m,
its mantle a prism of N = 48 facets (vertices on the circle of radius R, so the mantle's inner surface lies
between R cos(pi/N) = 0.03991 m at a facet's middle and R at its edges; the sagitta R (1 - cos(pi/N)) =
0.086 mm is 4 % of a particle's radius), its two end caps fans of N triangles around the axis.

- meshes/drum.stl: mantle + both caps (the scene's wall: the whole drum rotates, caps included).
- meshes/mantle.stl, meshes/caps.stl: the same triangles split, for a drum whose caps stand still.

Vertex coordinates are rounded to float32 and written as the shortest decimal of that value: VTK's STL
reader (the engine) keeps float32, LIGGGHTS reads doubles; rounded so, both read the same numbers. Unrounded
(cos and sin of 7.5 degree steps written to 10 digits), the engine's facets lay up to 1e-9 m off LIGGGHTS',
which changed the force of a 1e-4 m overlap by 1e-5 (relative) at every wall contact.

Normals point into the drum. Neither code uses the stored normal for contact (LIGGGHTS mesh/surface and the
engine compute it from the vertices; a mesh wall is two-sided), it is written for viewers.

    python make_meshes.py            # rewrites the three files; they are committed, this documents them
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

RADIUS = 0.04   # m, vertex radius of the mantle
LENGTH = 0.02   # m, along y, from -LENGTH/2 to +LENGTH/2
SEGMENTS = 48   # facets around the mantle

Triangle = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


def f32(value: float) -> float:
    """value rounded to the nearest float32 (exactly representable in both codes' readers)."""
    return float(np.float32(value))


def rim(y: float) -> list[tuple[float, float, float]]:
    """The N vertices of the rim at y, on the circle of radius R about the y axis (angle from +x towards +z)."""
    return [(f32(RADIUS * math.cos(2 * math.pi * k / SEGMENTS)), f32(y), f32(RADIUS * math.sin(2 * math.pi * k / SEGMENTS)))
            for k in range(SEGMENTS)]


def mantle() -> list[Triangle]:
    lo, hi = rim(-0.5 * LENGTH), rim(0.5 * LENGTH)
    triangles = []
    for k in range(SEGMENTS):
        j = (k + 1) % SEGMENTS
        triangles.append((lo[k], hi[k], lo[j]))
        triangles.append((lo[j], hi[k], hi[j]))
    return triangles


def caps() -> list[Triangle]:
    triangles = []
    for y in (-0.5 * LENGTH, 0.5 * LENGTH):
        ring, centre = rim(y), (0.0, y, 0.0)
        for k in range(SEGMENTS):
            triangles.append((centre, ring[k], ring[(k + 1) % SEGMENTS]))
    return triangles


def inward_normal(triangle: Triangle) -> tuple[float, float, float]:
    """Unit normal of the triangle, flipped to point towards the drum's centre."""
    a, b, c = triangle
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    centroid = [sum(p[i] for p in triangle) / 3 for i in range(3)]
    if sum(n[i] * centroid[i] for i in range(3)) > 0:  # points away from the origin: flip
        n = [-x for x in n]
    length = math.sqrt(sum(x * x for x in n))
    return (n[0] / length, n[1] / length, n[2] / length)


def write_stl(path: Path, name: str, triangles: list[Triangle]) -> None:
    lines = [f"solid {name}"]
    for triangle in triangles:
        n = inward_normal(triangle)
        lines.append(f"  facet normal {n[0]:.9e} {n[1]:.9e} {n[2]:.9e}")
        lines.append("    outer loop")
        lines += [f"      vertex {p[0]!r} {p[1]!r} {p[2]!r}" for p in triangle]
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append(f"endsolid {name}")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    folder = Path(__file__).resolve().parent / "meshes"
    folder.mkdir(exist_ok=True)
    write_stl(folder / "drum.stl", "drum", mantle() + caps())
    write_stl(folder / "mantle.stl", "mantle", mantle())
    write_stl(folder / "caps.stl", "caps", caps())


if __name__ == "__main__":
    main()
