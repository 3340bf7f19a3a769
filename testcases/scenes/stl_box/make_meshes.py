#!/usr/bin/env python3
"""Write the STL box (meshes/box.stl, ASCII, 12 triangles) and the two scenes that differ only in their walls.

The box is x, y in [-A, A], z in [0, 2 A] with A = 2^-5 m = 0.03125 m: every coordinate is a dyadic fraction,
exact in float32 (an STL file, and vtk's reader, keep float32) and in the decimal text, so the mesh faces lie
exactly on the planes of the plane-wall box. Each face is two triangles split along one diagonal; the faces are
closed (floor, ceiling, four sides), normals point into the box (written for viewers; a mesh wall is two-sided
and the engine computes normals from the vertices).

- box_planes.json: six axis-aligned plane walls at x = +-A, y = +-A, z = 0, z = 2 A.
- box_mesh.json: one mesh wall, meshes/box.stl.

Everything else is the same: 11 spheres (r = 1.5 ... 2.5 mm, Hertz + tangential history, friction 0.4,
e = 0.6, gravity) thrown at the faces, the diagonals that split them, the edges and the corners of the box,
0.3 s (30,000 steps of 1e-5 s); positions x, y, z of every sphere printed every 100 steps into
post/trajectory_<walls>.csv. A sphere whose centre is inside a convex box touches each face at the foot of its
perpendicular, a point inside the face (or on its diagonal): contact at faces and their shared edges must give
exactly the plane's force once (not twice at a diagonal, nor an edge contact next to a face contact), so the
two scenes must follow the same trajectories to round-off.

    python make_meshes.py            # rewrites meshes/box.stl, box_planes.json, box_mesh.json (committed)
"""
from __future__ import annotations

import json
from pathlib import Path

A = 0.03125          # m, half width of the box (2^-5); height 2 A
STEPS = 30000
DT = 1e-5            # s

#: the corners of the box by (ix, iy, iz) in {0, 1}: x = -A or A, y = -A or A, z = 0 or 2A
def corner(ix: int, iy: int, iz: int) -> tuple[float, float, float]:
    return (A if ix else -A, A if iy else -A, 2 * A if iz else 0.0)


#: each face as four corners in order around it, and its inward normal
FACES = [
    ("floor", [corner(0, 0, 0), corner(1, 0, 0), corner(1, 1, 0), corner(0, 1, 0)], (0, 0, 1)),
    ("ceiling", [corner(0, 0, 1), corner(0, 1, 1), corner(1, 1, 1), corner(1, 0, 1)], (0, 0, -1)),
    ("left", [corner(0, 0, 0), corner(0, 1, 0), corner(0, 1, 1), corner(0, 0, 1)], (1, 0, 0)),
    ("right", [corner(1, 0, 0), corner(1, 0, 1), corner(1, 1, 1), corner(1, 1, 0)], (-1, 0, 0)),
    ("front", [corner(0, 0, 0), corner(0, 0, 1), corner(1, 0, 1), corner(1, 0, 0)], (0, 1, 0)),
    ("back", [corner(0, 1, 0), corner(1, 1, 0), corner(1, 1, 1), corner(0, 1, 1)], (0, -1, 0)),
]

#: the plane walls of the same box: (name, axis, position)
PLANES = [("floor", "z", 0.0), ("ceiling", "z", 2 * A), ("left", "x", -A), ("right", "x", A),
          ("front", "y", -A), ("back", "y", A)]

#: (radius m, position m, velocity m/s, omega rad/s), each aimed at a face, a diagonal, an edge or a corner
SPHERES = [
    (0.0020, [0.0, 0.0, 0.030], [0.0, 0.0, -0.5], [0.0, 0.0, 0.0]),            # floor, on the diagonal's middle
    (0.0020, [0.012, 0.012, 0.045], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),          # floor diagonal, off centre
    (0.0025, [-0.015, 0.010, 0.020], [-0.6, 0.05, 0.3], [0.0, 5.0, 0.0]),       # left face, spinning
    (0.0015, [0.020, -0.018, 0.010], [0.7, -0.6, -0.2], [1.0, 0.0, 3.0]),       # edge right/front
    (0.0020, [-0.020, -0.020, 0.050], [-0.6, -0.6, 0.4], [0.0, 0.0, 0.0]),      # corner left/front/ceiling
    (0.0022, [0.018, 0.020, 0.035], [0.5, 0.6, -0.9], [-4.0, 2.0, 0.0]),        # corner right/back/floor
    (0.0018, [-0.022, 0.024, 0.008], [0.0, 0.8, 0.0], [0.0, 0.0, 10.0]),        # back face, rolling on the floor
    (0.0020, [0.005, -0.010, 0.055], [0.1, -0.2, 0.9], [0.0, 0.0, 0.0]),        # ceiling
    (0.0016, [-0.008, -0.024, 0.040], [0.3, -0.2, -0.3], [0.0, 0.0, 0.0]),      # front face, slides down
    (0.0024, [0.024, 0.002, 0.025], [0.4, 0.0, 0.0], [0.0, -6.0, 0.0]),         # right face, diagonal region
    (0.0020, [-0.02625, 0.02625, 0.00749], [-0.3, 0.3, -0.5], [0.0, 0.0, 0.0]),   # corner left/back/floor at once
]


def triangles() -> list[tuple[str, tuple, list]]:
    """(face, inward normal, three vertices) for the 12 triangles: each quad split along corners 0-2."""
    out = []
    for name, (p0, p1, p2, p3), normal in FACES:
        out.append((name, normal, [p0, p1, p2]))
        out.append((name, normal, [p0, p2, p3]))
    return out


def write_ascii_stl(path: Path) -> None:
    lines = ["solid box"]
    for _, normal, vertices in triangles():
        lines.append("  facet normal %r %r %r" % tuple(float(c) for c in normal))
        lines.append("    outer loop")
        lines += ["      vertex %r %r %r" % tuple(v) for v in vertices]
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid box")
    path.write_text("\n".join(lines) + "\n")


def scene(walls: str) -> list[dict]:
    """The command list of the box of `walls`: 'planes' or 'mesh'."""
    commands = [
        {"command": "create", "object": "domain", "lo": [-2 * A, -2 * A, -A], "hi": [2 * A, 2 * A, 3 * A]},
        {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.3,
         "density": 2500},
        {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.6, "friction": 0.4},
        {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
    ]
    if walls == "planes":
        commands += [{"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis,
                      "position": position, "type": 1} for name, axis, position in PLANES]
    else:
        commands.append({"command": "create", "object": "wall", "name": "box", "shape": "mesh",
                         "file": "meshes/box.stl", "type": 1})
    for radius, position, velocity, omega in SPHERES:
        commands.append({"command": "create", "object": "particle", "type": 1, "radius": radius,
                         "position": position, "velocity": velocity, "omega": omega})
    positions = [f"{axis}[{i}]" for i in range(1, len(SPHERES) + 1) for axis in "xyz"]
    commands += [
        {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity",
         "acceleration": [0, 0, -9.81]},
        {"command": "fix", "name": "gravity"},
        {"command": "set", "property": "timestep", "value": DT},
        {"command": "set", "property": "thermo", "every": 500, "columns": ["contacts", "max_overlap"]},
        {"command": "create", "object": "modifier", "name": "trajectory", "kind": "print", "every": 100,
         "file": f"post/trajectory_{walls}.csv", "quantities": positions},
        {"command": "fix", "name": "trajectory"},
        {"command": "run", "steps": STEPS},
    ]
    return commands


def write_scene(path: Path, commands: list[dict]) -> None:
    path.write_text("[\n" + ",\n".join(" " + json.dumps(c) for c in commands) + "\n]\n")


def main() -> None:
    here = Path(__file__).resolve().parent
    (here / "meshes").mkdir(exist_ok=True)
    write_ascii_stl(here / "meshes" / "box.stl")
    write_scene(here / "box_planes.json", scene("planes"))
    write_scene(here / "box_mesh.json", scene("mesh"))


if __name__ == "__main__":
    main()
