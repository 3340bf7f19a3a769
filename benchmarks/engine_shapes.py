"""What clumps cost, and that spheres cost what they cost before clumps (engine/clumps.py).

Part 1, spheres: the same sphere scene (a lattice block of side^3 spheres with tangential history under
gravity in a box of five planes) run by the engine of a base revision (`git archive REV engine`, default the
commit before the clumps) and by this working tree, in alternating pairs; the figure is the loop CPU time per
particle-step (`cpu` / `particle_steps` of timing.json: compile and set-up excluded, time spent waiting for a
core on a shared machine too). Printed: each engine's median and the ratio new / base.

Part 2, clumps: a settling pile of N two-sphere clumps (aspect ratio 2) against 2 N free spheres of the same
radius, same box, same contact model: member-sphere steps and body steps per CPU second.

Part 3, superquadrics (engine/superquadrics.py): a settling pile of M superquadrics of half-axes 2r, r, r
(aspect ratio 2; ellipsoids, n = 2, and blocky, n = 6) against M spheres of radius r, same box, same contact
model: body-steps per CPU second.

Part 4, the superquadrics' pair search: piles of ellipsoids as in part 3 with the box widened as sqrt(N / 300),
so that the height stays the same, for N = 300 and 3000, run by the engine of --sq-base (the all-pairs search)
and by this working tree (the cell grid), alternating: body-steps per CPU second of each.

    python benchmarks/engine_shapes.py [--base REV] [--side 16] [--steps 2000] [--repeat 3] [--clumps 1000]
                                       [--superquadrics 300] [--sq-steps 20000] [--parts 1,2,3,4]
                                       [--sq-base REV] [--grid-steps 2000]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
R = 0.0015
MATERIAL = [
    {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.45,
     "density": 2500},
    {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3},
    {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
    {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity"},
    {"command": "fix", "name": "gravity"},
    {"command": "set", "property": "timestep", "value": 1e-5},
]


def box_walls(extent: float) -> list:
    return [{"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis, "position": pos,
             "type": 1} for name, axis, pos in (("floor", "z", 0.0), ("x0", "x", 0.0), ("x1", "x", extent),
                                                 ("y0", "y", 0.0), ("y1", "y", extent))]


def sphere_block(side: int, steps: int) -> list:
    spacing = 2 * R * 0.998
    extent = side * spacing
    return ([{"command": "create", "object": "domain", "lo": [-0.1, -0.1, -0.1], "hi": [0.1, 0.1, 0.1]}]
            + MATERIAL + box_walls(extent)
            + [{"command": "create", "object": "lattice", "type": 1, "radius": R, "spacing": spacing,
                "region": {"shape": "box", "lo": [0, 0, 0], "hi": [extent, extent, extent]}},
               {"command": "run", "steps": steps}])


def pile(count: int, clumps: bool, steps: int) -> list:
    """count two-sphere clumps (or 2 count spheres) packed at random in a tall box, settling."""
    width = 0.03
    height = 0.0006 * count * (2 if clumps else 1) / (width / 0.03) ** 2 + 0.02
    region = {"shape": "box", "lo": [0.0, 0.0, 0.0], "hi": [width, width, height]}
    commands = [{"command": "create", "object": "domain", "lo": [-0.01, -0.01, -0.01],
                 "hi": [width + 0.01, width + 0.01, height + 0.01]}] + MATERIAL + box_walls(width)
    if clumps:
        commands += [{"command": "create", "object": "clump_template", "name": "pair", "type": 1,
                      "spheres": [[-R, 0, 0, R], [R, 0, 0, R]]},
                     {"command": "create", "object": "clump_packing", "template": "pair", "count": count, "seed": 1,
                      "region": region}]
    else:
        commands.append({"command": "create", "object": "random_packing", "type": 1, "radius": R,
                         "count": 2 * count, "seed": 1, "region": region})
    return commands + [{"command": "run", "steps": steps}]


def superquadric_pile(count: int, blockiness: float | None, steps: int, width: float = 0.03) -> list:
    """count superquadrics of half-axes 2r, r, r and the given blockiness packed at random in a tall box of the
    given width (m; or, for blockiness None, count spheres of radius r), settling."""
    height = 0.0012 * count / (width / 0.03) ** 2 + 0.02
    region = {"shape": "box", "lo": [0.0, 0.0, 0.0], "hi": [width, width, height]}
    commands = [{"command": "create", "object": "domain", "lo": [-0.01, -0.01, -0.01],
                 "hi": [width + 0.01, width + 0.01, height + 0.01]}] + MATERIAL + box_walls(width)
    if blockiness is None:
        commands.append({"command": "create", "object": "random_packing", "type": 1, "radius": R, "count": count,
                         "seed": 1, "region": region})
    else:
        commands.append({"command": "create", "object": "superquadric_packing", "type": 1,
                         "half_axes": [2 * R, R, R], "blockiness": blockiness, "count": count, "seed": 1,
                         "region": region})
    return commands + [{"command": "run", "steps": steps}]


def loop_cpu(engine_root: Path, commands: list) -> dict:
    """timing.json of one run of the scene by the engine under engine_root (one thread)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "scene.json").write_text(json.dumps(commands))
        env = dict(os.environ, PYTHONPATH=str(engine_root))
        done = subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json", "-threads", "1"], cwd=folder,
                              env=env, capture_output=True, text=True)
        if done.returncode:
            raise SystemExit(done.stdout[-2000:] + done.stderr[-2000:])
        return json.loads((folder / "timing.json").read_text())


def pair_search(args):
    print(f"pair search: ellipsoid piles (half-axes 2r, r, r), {args.grid_steps} steps, one thread; "
          f"base {args.sq_base} against this tree")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        archive = subprocess.run(["git", "archive", args.sq_base, "engine"], cwd=REPO, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
        for count in (300, 3000):
            width = 0.03 * (count / 300) ** 0.5
            for _ in range(args.repeat):
                rates = []
                for name, root in (("base", base), ("new", REPO)):
                    loop_cpu(root, superquadric_pile(count, 2, 10, width))  # compile outside the timed run
                    t = loop_cpu(root, superquadric_pile(count, 2, args.grid_steps, width))
                    rates.append(t["particle_steps"] / t["cpu"])
                print(f"  {count} bodies: base {rates[0]:.3g}, this {rates[1]:.3g} body-steps per CPU s "
                      f"(ratio {rates[1] / rates[0]:.2f})")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--base", default="3579291", help="revision of the engine before clumps")
    parser.add_argument("--side", type=int, default=16)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--clumps", type=int, default=1000)
    parser.add_argument("--superquadrics", type=int, default=300)
    parser.add_argument("--sq-steps", type=int, default=20000, help="steps of part 3 (the pile settles in about 0.2 s)")
    parser.add_argument("--parts", default="1,2,3", help="which parts to run (comma-separated; 4 on request)")
    parser.add_argument("--sq-base", default="94574c4", help="revision of part 4's base (superquadric pairs all against all)")
    parser.add_argument("--grid-steps", type=int, default=2000, help="steps of part 4")
    args = parser.parse_args()
    parts = {int(p) for p in args.parts.split(",")}
    if 1 in parts:
        spheres_against_base(args)
    if 2 in parts:
        clump_pile(args)
    if 3 in parts:
        superquadric_piles(args)
    if 4 in parts:
        pair_search(args)


def spheres_against_base(args):
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        archive = subprocess.run(["git", "archive", args.base, "engine"], cwd=REPO, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
        scene = sphere_block(args.side, args.steps)
        for root in (base, REPO):  # compile (or load) both kernels outside the timed runs
            loop_cpu(root, sphere_block(args.side, 10))
        per = {"base": [], "new": []}
        for _ in range(args.repeat):
            for name, root in (("base", base), ("new", REPO)):
                t = loop_cpu(root, scene)
                per[name].append(1e9 * t["cpu"] / t["particle_steps"])
    b, n = statistics.median(per["base"]), statistics.median(per["new"])
    print(f"spheres, {args.side ** 3} in a block, {args.steps} steps, one thread; loop CPU ns per particle-step")
    print(f"  base {args.base}: {b:.2f} (runs {', '.join(f'{v:.2f}' for v in per['base'])})")
    print(f"  this tree:      {n:.2f} (runs {', '.join(f'{v:.2f}' for v in per['new'])})")
    print(f"  ratio this / base: {n / b:.3f}")


def clump_pile(args):
    print(f"settling pile, {args.steps} steps, one thread")
    for clumps in (False, True):
        loop_cpu(REPO, pile(args.clumps, clumps, 10))
        t = loop_cpu(REPO, pile(args.clumps, clumps, args.steps))
        spheres = t["particle_steps"] / t["cpu"]
        bodies = spheres / 2 if clumps else spheres
        what = f"{args.clumps} clumps of 2 spheres" if clumps else f"{2 * args.clumps} spheres"
        print(f"  {what}: {spheres:.3g} sphere-steps per CPU s, {bodies:.3g} body-steps per CPU s")


def superquadric_piles(args):
    print(f"settling pile of {args.superquadrics} bodies (half-axes 2r, r, r), {args.sq_steps} steps, one thread")
    for blockiness in (None, 2, 6):
        loop_cpu(REPO, superquadric_pile(args.superquadrics, blockiness, 10))
        t = loop_cpu(REPO, superquadric_pile(args.superquadrics, blockiness, args.sq_steps))
        what = "spheres of radius r" if blockiness is None else f"superquadrics, n = {blockiness}"
        print(f"  {what}: {t['particle_steps'] / t['cpu']:.3g} body-steps per CPU s")


if __name__ == "__main__":
    main()
