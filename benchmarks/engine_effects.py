"""What each effect costs: time per particle-step of one scene with growing sets of effects (issue 2, 5).

The scene: a block of N = 20^3 spheres (r = 1.5 mm) on a simple cubic lattice with 0.2 % overlap, so every
sphere has six contacts all the time, falling under gravity. Variants: Hertz normal only; + tangential
history; + SJKR cohesion; + CDT rolling friction; + EPSD2 instead of CDT; + five plane walls around the
block. Every variant compiles its own kernel (first run only; cached on disk). The figure is CPU time per
particle-step: (CPU of a run with the timed steps - CPU of the same script without them) / (steps N), which
cancels start-up and set-up and does not count time the process waited for a core on a shared machine.

    python benchmarks/engine_effects.py [--steps 2000] [--side 20] [--repeat 2]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
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


def cpu_seconds(folder: Path, env: dict) -> float:
    """User + system CPU time of one engine process (os.wait4): robust on a shared machine."""
    proc = subprocess.Popen([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=folder, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status):
        raise SystemExit(proc.stderr.read().decode())
    return usage.ru_utime + usage.ru_stime


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--side", type=int, default=20, help="spheres per lattice edge (N = side^3)")
    parser.add_argument("--repeat", type=int, default=2, help="timed pairs of runs per variant (the best counts)")
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=str(REPO))
    n = args.side ** 3
    base = None
    print(f"N = {n}, {args.steps} steps; CPU time of a run with the steps minus one without them")
    print(f"{'effects':<34} {'ns / particle-step':>19} {'relative':>9}")
    for label, options in VARIANTS:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            short = folder / "short"
            long = folder / "long"
            for sub, steps in ((short, 0), (long, args.steps)):
                sub.mkdir()
                (sub / "scene.json").write_text(json.dumps(scene(args.side, steps, **options)))
            cpu_seconds(short, env)  # compiles the kernel, or loads it from the disk cache
            per = min((cpu_seconds(long, env) - cpu_seconds(short, env)) / (args.steps * n) * 1e9
                      for _ in range(args.repeat))
        base = base or per
        print(f"{label:<34} {per:>19.1f} {per / base:>9.2f}", flush=True)


if __name__ == "__main__":
    main()
