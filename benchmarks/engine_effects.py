"""What each effect costs: time per particle-step of one scene with growing sets of effects (issue 2, 5).

The scene: a block of N = 20^3 spheres (r = 1.5 mm) on a simple cubic lattice with 0.2 % overlap, so every
sphere has six contacts all the time, falling under gravity. Variants: Hertz normal only; + tangential
history; + SJKR cohesion; + CDT rolling friction; + EPSD2 instead of CDT; + five plane walls around the
block. Every variant compiles its own kernel (first run only; cached on disk), and the figure is the loop
time per particle-step from the engine's log.

    python benchmarks/engine_effects.py [--steps 2000] [--side 20] [--repeat 3]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LOOP = re.compile(r"Loop time of ([\d.e+-]+) s for (\d+) steps with (\d+) particles")
R = 0.0015


def scene(side: int, steps: int, tangential="none", cohesion="none", rolling="none", walls=False) -> list:
    spacing = 2 * R * 0.998
    extent = side * spacing
    commands = [
        {"command": "create", "object": "domain", "lo": [-0.1, -0.1, -0.1], "hi": [0.1, 0.1, 0.1]},
        {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.45,
         "density": 2500},
        {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3,
         "rolling_friction": 0.05, "cohesion_energy_density": 1e3},
        {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": tangential,
         "cohesion": cohesion, "rolling": rolling},
        {"command": "create", "object": "lattice", "type": 1, "radius": R, "spacing": spacing,
         "region": {"shape": "box", "lo": [0, 0, 0], "hi": [extent, extent, extent]}},
        {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity"},
        {"command": "fix", "name": "gravity"},
        {"command": "set", "property": "timestep", "value": 1e-5},
    ]
    if walls:
        for name, axis, pos in (("floor", "z", 0.0), ("x0", "x", 0.0), ("x1", "x", extent), ("y0", "y", 0.0),
                                ("y1", "y", extent)):
            commands.append({"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis,
                             "position": pos, "type": 1})
    return commands + [{"command": "run", "steps": 10}, {"command": "run", "steps": steps}]


VARIANTS = [
    ("normal only (Hertz)", {}),
    ("+ tangential history", dict(tangential="history")),
    ("+ cohesion SJKR", dict(tangential="history", cohesion="sjkr")),
    ("+ rolling CDT", dict(tangential="history", cohesion="sjkr", rolling="cdt")),
    ("+ rolling EPSD2 (instead of CDT)", dict(tangential="history", cohesion="sjkr", rolling="epsd2")),
    ("+ walls (5 planes, with CDT)", dict(tangential="history", cohesion="sjkr", rolling="cdt", walls=True)),
]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--side", type=int, default=20, help="spheres per lattice edge (N = side^3)")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per variant (the best counts)")
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=str(REPO))
    base = None
    print(f"{'effects':<34} {'ns / particle-step':>19} {'relative':>9}")
    for label, options in VARIANTS:
        with tempfile.TemporaryDirectory() as tmp:
            (Path(tmp) / "scene.json").write_text(json.dumps(scene(args.side, args.steps, **options)))
            # first call compiles (or loads from the disk cache); then the best of `repeat` timed runs,
            # since the machine is shared and a neighbor's job only ever makes a run slower
            timings = []
            for attempt in range(1 + args.repeat):
                proc = subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=tmp, env=env,
                                      capture_output=True, text=True)
                if proc.returncode:
                    raise SystemExit(proc.stderr)
                seconds, steps, n = LOOP.findall((Path(tmp) / "log.dem").read_text())[-1]
                if attempt:
                    timings.append(float(seconds) / (int(steps) * int(n)) * 1e9)
        per = min(timings)
        base = base or per
        print(f"{label:<34} {per:>19.1f} {per / base:>9.2f}", flush=True)


if __name__ == "__main__":
    main()
