#!/usr/bin/env python3
"""Write the hopper's STL files (binary, metres) into meshes/: one silo per orifice diameter.

The hopper is a flat-bottomed cylindrical silo, axis z, centred on the origin: a bottom plate at z = 0 with a
circular orifice of diameter D in its middle, and a mantle of radius R = 0.04 m up to z = H = 0.16 m (open at
the top). Beverloo's correlation (W = C rho_b sqrt(g) (D - k d)^(5/2), C = 0.58, k about 1.4-1.5) was measured
on flat-bottomed bins (Beverloo, Leniger, van de Velde 1961, Chem. Eng. Sci. 15, 260; Nedderman, Tuzun,
Savage, Houlsby 1982, Chem. Eng. Sci. 37, 1597): a conical bottom steeper than the stagnant zone that forms
on a flat bottom speeds the flow up by the hopper-angle factor of Rose and Tanaka (1956), so C would no
longer be Beverloo's. `--bottom-angle A` still writes a conical bottom rising at A degrees from the
horizontal from the orifice's edge to the mantle (a conical hopper), for other uses.

Circles are polygons of N = 64 sides whose vertices lie on the radius of the circle of the same area,
r_v = r sqrt(2 pi / (N sin(2 pi / N))) = 1.0008 r: the orifice's area is pi D^2 / 4 exactly (Beverloo's D is
the diameter of a circular orifice of that area). The bottom plate is split into rings about 6 mm wide and the
mantle into bands 10 mm high, so that no triangle is much longer than a few particle diameters (a mesh's
triangles are binned by their bounding boxes). Normals point into the silo (neither the engine nor LIGGGHTS
reads them for contact; a mesh wall is two-sided).

    python make_meshes.py            # rewrites meshes/hopper_D20.stl, _D24.stl, _D28.stl (D in mm)

The files are committed: this script documents them.
"""
from __future__ import annotations

import argparse
import math
import struct
from pathlib import Path

RADIUS = 0.040          # m, silo radius R (10 particle diameters of 4 mm)
HEIGHT = 0.160          # m, top of the mantle
ORIFICES_MM = (20, 24, 28)   # orifice diameters D in mm: D/d = 5, 6, 7 for d = 4 mm
SEGMENTS = 64           # polygon sides of every circle
RING_WIDTH = 0.006      # m, target width of the bottom plate's rings
BAND_HEIGHT = 0.010     # m, target height of the mantle's bands

Vertex = tuple[float, float, float]
Triangle = tuple[Vertex, Vertex, Vertex]


def vertex_radius(radius: float) -> float:
    """Radius of the vertices of an N-gon whose area is that of the circle of this radius (m)."""
    return radius * math.sqrt(2 * math.pi / (SEGMENTS * math.sin(2 * math.pi / SEGMENTS)))


def ring(radius: float, z: float) -> list[Vertex]:
    """The N vertices of the polygon of the circle of this radius at height z (angle from +x towards +y)."""
    rv = vertex_radius(radius)
    return [(rv * math.cos(2 * math.pi * k / SEGMENTS), rv * math.sin(2 * math.pi * k / SEGMENTS), z)
            for k in range(SEGMENTS)]


def strip(lower: list[Vertex], upper: list[Vertex]) -> list[Triangle]:
    """Two triangles per side between two rings of N vertices (a band of the mantle or a ring of the bottom)."""
    triangles = []
    for k in range(SEGMENTS):
        j = (k + 1) % SEGMENTS
        triangles.append((lower[k], lower[j], upper[k]))
        triangles.append((lower[j], upper[j], upper[k]))
    return triangles


def hopper(orifice: float, bottom_angle: float = 0.0) -> list[Triangle]:
    """Triangles of the silo with an orifice of diameter `orifice` (m); bottom rising at `bottom_angle` degrees."""
    slope = math.tan(math.radians(bottom_angle))
    rings = max(1, round((RADIUS - 0.5 * orifice) / RING_WIDTH))
    radii = [0.5 * orifice + (RADIUS - 0.5 * orifice) * i / rings for i in range(rings + 1)]
    bottom = [ring(r, (r - 0.5 * orifice) * slope) for r in radii]
    triangles = []
    for inner, outer in zip(bottom, bottom[1:]):
        triangles += strip(inner, outer)
    z_edge = (RADIUS - 0.5 * orifice) * slope
    bands = max(1, round((HEIGHT - z_edge) / BAND_HEIGHT))
    levels = [ring(RADIUS, z_edge + (HEIGHT - z_edge) * i / bands) for i in range(bands + 1)]
    for lower, upper in zip(levels, levels[1:]):
        triangles += strip(lower, upper)
    return triangles


def inward_normal(triangle: Triangle) -> Vertex:
    """Unit normal of the triangle, flipped to point into the silo (towards the axis, or up on the bottom)."""
    a, b, c = triangle
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    length = math.sqrt(sum(x * x for x in n))
    n = [x / length for x in n]
    centroid = [sum(p[i] for p in triangle) / 3 for i in range(3)]
    if abs(n[2]) > 0.5:   # bottom: point up
        flip = n[2] < 0
    else:                 # mantle: point towards the axis
        flip = n[0] * centroid[0] + n[1] * centroid[1] > 0
    return tuple(-x for x in n) if flip else tuple(n)


def write_binary_stl(path: Path, name: str, triangles: list[Triangle]) -> None:
    """Binary STL: 80-byte header, uint32 count, per triangle 12 float32 (normal, 3 vertices) + uint16 0."""
    header = f"{name} (testcases/scenes/hopper/make_meshes.py, metres)".encode()[:80].ljust(80, b" ")
    with open(path, "wb") as out:
        out.write(header)
        out.write(struct.pack("<I", len(triangles)))
        for triangle in triangles:
            out.write(struct.pack("<12fH", *inward_normal(triangle), *(x for p in triangle for x in p), 0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bottom-angle", type=float, default=0.0,
                        help="degrees from the horizontal of a conical bottom (default 0: flat)")
    args = parser.parse_args()
    folder = Path(__file__).resolve().parent / "meshes"
    folder.mkdir(exist_ok=True)
    for d_mm in ORIFICES_MM:
        triangles = hopper(d_mm / 1000.0, args.bottom_angle)
        write_binary_stl(folder / f"hopper_D{d_mm}.stl", f"hopper_D{d_mm}", triangles)
        print(f"meshes/hopper_D{d_mm}.stl: {len(triangles)} triangles")


if __name__ == "__main__":
    main()
