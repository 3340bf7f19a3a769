"""What mesh walls cost against plane walls per particle-step (issue 12: at most 2x), side by side.

The same scene twice: N spheres of r = 1.5 mm packed at random into a box of five walls (floor and four sides,
open top), Hertz + tangential history, gravity, dt = 1e-5 s, SETTLE steps of pouring and settling, then MEASURE
steps on the resting bed. The walls are either five axis-aligned planes or one STL mesh of the same box, two
triangles per face (10 triangles, written into a temporary folder; coordinates are multiples of 2^-10 m, so
exact in the STL's float32 and the mesh faces lie exactly on the planes). The two configurations alternate
within each repetition so that the machine's load hits both alike. Figures are the engine's own loop times
(the `Loop time of X s for N steps` lines of the log: stepping without start-up or compilation), the median
over repetitions, per particle-step, and their ratio mesh/plane for the pouring and for the resting bed. The
wall contacts (spheres within their radius of a wall) of the resting bed are counted from a final VTK dump, so
that the extra cost per wall contact can be read too: (t_mesh - t_plane) / (wall contacts x steps).

    python benchmarks/mesh_contacts.py                         # N = 5000, 20000 + 2000 steps, 3 repetitions
    python benchmarks/mesh_contacts.py --sizes 2000 10000 --repeat 5 --threads 2
    python benchmarks/mesh_contacts.py --subdivide 8    # each face 8 x 8 quads: 640 triangles, the same box
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RADIUS = 0.0015  # m
sys.path.insert(0, str(REPO))  # the harness' adapters read the logs
from harness.adapters import get_adapter  # noqa: E402

GRID = 2.0 ** -10  # m: box coordinates are multiples of this (exact in float32)


def box_size(n: int) -> tuple[float, float]:
    """(half width, packing height) m: half width 0.015 sqrt(N / 2500) rounded to the grid, packed at a solid
    fraction of 0.28 (so random sequential addition fits), the same bed height for every N."""
    half_width = round(0.015 * math.sqrt(n / 2500) / GRID) * GRID
    usable = (2 * half_width - 2 * RADIUS) ** 2
    return half_width, n * 4 / 3 * math.pi * RADIUS ** 3 / (0.28 * usable) + 2 * RADIUS


def box_stl(path: Path, half_width: float, height: float, subdivide: int = 1) -> int:
    """ASCII STL of the open box: floor and four sides, each a grid of K x K quads of two triangles (K =
    subdivide; 1: two triangles per face). Returns the number of triangles."""
    a, h = half_width, height
    faces = [[(-a, -a, 0), (a, -a, 0), (a, a, 0), (-a, a, 0)],       # floor
             [(-a, -a, 0), (-a, a, 0), (-a, a, h), (-a, -a, h)],     # x = -a
             [(a, -a, 0), (a, -a, h), (a, a, h), (a, a, 0)],         # x = +a
             [(-a, -a, 0), (-a, -a, h), (a, -a, h), (a, -a, 0)],     # y = -a
             [(-a, a, 0), (a, a, 0), (a, a, h), (-a, a, h)]]         # y = +a

    def lerp(p, q, t):
        return tuple(pc + (qc - pc) * t for pc, qc in zip(p, q))

    quads = []
    k = subdivide
    for c0, c1, c2, c3 in faces:  # bilinear grid on the face; K a power of two keeps every vertex exact
        point = lambda i, j: lerp(lerp(c0, c1, i / k), lerp(c3, c2, i / k), j / k)
        quads += [(point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1))
                  for i in range(k) for j in range(k)]
    lines = ["solid box"]
    for p0, p1, p2, p3 in quads:
        for tri in ((p0, p1, p2), (p0, p2, p3)):
            lines += ["  facet normal 0 0 0", "    outer loop"]
            lines += ["      vertex %r %r %r" % tuple(float(c) for c in v) for v in tri]
            lines += ["    endloop", "  endfacet"]
    lines.append("endsolid box")
    path.write_text("\n".join(lines) + "\n")
    return 2 * len(quads)


def scene(walls: str, n: int, settle: int, measure: int) -> list[dict]:
    half_width, height = box_size(n)
    a = half_width
    commands = [
        {"command": "create", "object": "domain", "lo": [-a, -a, -0.01], "hi": [a, a, height + 0.02]},
        {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.45,
         "density": 2500},
        {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3},
        {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
    ]
    if walls == "plane":
        commands += [{"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis,
                      "position": position, "type": 1}
                     for name, axis, position in (("floor", "z", 0.0), ("left", "x", -a), ("right", "x", a),
                                                  ("front", "y", -a), ("back", "y", a))]
    else:
        commands.append({"command": "create", "object": "wall", "name": "box", "shape": "mesh",
                         "file": "box.stl", "type": 1})
    commands += [
        {"command": "create", "object": "random_packing", "type": 1, "count": n, "seed": 1, "radius": RADIUS,
         "region": {"shape": "box", "lo": [-a, -a, 0.0], "hi": [a, a, height]}},
        {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity",
         "acceleration": [0, 0, -9.81]},
        {"command": "fix", "name": "gravity"},
        {"command": "set", "property": "timestep", "value": 1e-5},
        {"command": "set", "property": "thermo", "every": 1000, "columns": ["contacts"]},
        {"command": "run", "steps": settle},
        {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": measure,
         "folder": "post", "prefix": "bed"},
        {"command": "fix", "name": "dump"},  # writes the bed at the start and the end of the measured run
        {"command": "run", "steps": measure},
    ]
    return commands


def wall_contacts(folder: Path, half_width: float) -> int:
    """Spheres of the last dump within their radius of the floor or a side (a sphere in a corner counts twice)."""
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    dump = sorted((folder / "post").glob("bed_*.vtp"))[-1]
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(dump))
    reader.Update()
    points = vtk_to_numpy(reader.GetOutput().GetPoints().GetData())
    radius = vtk_to_numpy(reader.GetOutput().GetPointData().GetArray("radius"))
    gaps = [points[:, 2], points[:, 0] + half_width, half_width - points[:, 0], points[:, 1] + half_width,
            half_width - points[:, 1]]
    return int(sum(int((g < radius).sum()) for g in gaps))


def run(walls: str, n: int, settle: int, measure: int, threads: int, subdivide: int = 1) -> tuple[float, float, int]:
    """(pouring loop time, resting-bed loop time) in s and the resting bed's wall contacts, of one engine run."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        half_width, height = box_size(n)
        box_stl(folder / "box.stl", half_width, height + 0.01, subdivide)
        (folder / "scene.json").write_text(json.dumps(scene(walls, n, settle, measure)))
        cmd = [sys.executable, "-m", "engine", "-in", "scene.json", "-log", "log.dem", "-threads", str(threads)]
        env = dict(os.environ, PYTHONPATH=str(REPO))
        proc = subprocess.run(cmd, cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if proc.returncode:
            raise SystemExit(f"{walls} walls, N = {n}: engine failed: {proc.stderr.strip()[-500:]}")
        loops = get_adapter("dem").loop_blocks(folder)
        return loops[0].seconds, loops[1].seconds, wall_contacts(folder, half_width)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[5000])
    parser.add_argument("--settle", type=int, default=20000)
    parser.add_argument("--measure", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--subdivide", type=int, default=1,
                        help="K: each face of the mesh a K x K grid of quads (2 K^2 triangles; default 1)")
    args = parser.parse_args()
    configs = ["plane", "mesh"]
    for walls in configs:  # compile (or load) both kernels once, outside the figures
        run(walls, 500, 10, 10, args.threads)
    for n in args.sizes:
        times = {c: [] for c in configs}
        contacts = {}
        for rep in range(args.repeat):
            for walls in (configs if rep % 2 == 0 else configs[::-1]):
                settle, measure, contacts[walls] = run(walls, n, args.settle, args.measure, args.threads,
                                                       args.subdivide)
                times[walls].append((settle, measure))
                print(f"N={n} rep {rep + 1}: {walls:<5} pouring {settle:.2f} s, resting bed {measure:.3f} s, "
                      f"{contacts[walls]} wall contacts", flush=True)
        median = {c: (statistics.median(t[0] for t in times[c]), statistics.median(t[1] for t in times[c]))
                  for c in configs}
        print(f"\nN = {n}, {args.threads} thread(s), mesh of {10 * args.subdivide ** 2} triangles: {args.settle} steps "
              f"pouring + {args.measure} steps resting bed, median of {args.repeat} (loop times)")
        print(f"{'walls':<6} {'pouring ns/particle-step':>25} {'resting ns/particle-step':>25} {'wall contacts':>14}")
        for c in configs:
            print(f"{c:<6} {1e9 * median[c][0] / (n * args.settle):>25.1f} "
                  f"{1e9 * median[c][1] / (n * args.measure):>25.1f} {contacts[c]:>14}")
        ratio_pour = median["mesh"][0] / median["plane"][0]
        ratio_bed = median["mesh"][1] / median["plane"][1]
        extra = (median["mesh"][1] - median["plane"][1]) / (max(contacts["mesh"], 1) * args.measure)
        print(f"mesh/plane: pouring {ratio_pour:.2f}x, resting bed {ratio_bed:.2f}x (issue 12 asks <= 2x); "
              f"extra cost per wall contact on the resting bed {1e9 * extra:.0f} ns per step\n")


if __name__ == "__main__":
    main()
