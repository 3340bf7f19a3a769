"""The rotating drum's steps, engine builds side by side: small scenes with many steps (the main job's longest
engine runs, testcases/shapes/drum_repose and testcases/scenes/drum).

Scenes (the test cases' own scripts and STL mesh, with fewer steps; thermo every 500 steps, VTK every 5000):
- `spheres`: 576 spheres in the rotating mesh drum (drum_repose spheres.json);
- `dumbbells`: 288 two-sphere clumps (576 members) inserted into it (drum_repose clumps.json, seed 1);
- `rotating`: testcases/scenes/drum scene.json (576 spheres, the same drum);
- `hopper`: testcases/scenes/hopper scene.json, D = 20 mm (6,000 spheres draining through a static mesh hopper of
  2,688 triangles, an outlet every 100 steps).

Each build is a folder holding engine/ (an old commit: `git archive main engine | tar -x -C /tmp/drum-old`).
Builds alternate within each repetition, so that the machine's load hits them alike, on one thread. Printed per
scene and build: the engine's own loop time (the `Loop time` line: stepping without start-up or compilation)
per step in us and per particle-step in ns (median over repetitions), the phases of timing.json per step, and
the ratio of the loop time to the first build's; then whether every output file (thermo.csv, print files, VTK
dumps) is byte for byte the first build's.

    git archive main engine | tar -x -C /tmp/drum-old
    python benchmarks/engine_drum.py --builds /tmp/drum-old . --steps 20000 --repeat 3
    python benchmarks/engine_drum.py --builds /tmp/drum-old . --scenes dumbbells --steps 60000
    python benchmarks/engine_drum.py --builds /tmp/drum-old . --scenes hopper --steps 5000
"""
from __future__ import annotations

import argparse
import filecmp
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DRUM = dict(thermo_every=500, dump_every=5000, omega=2.0, vx0=0.0)
#: scene -> (test case folder, script, variables but the steps, the name of the steps variable)
SCENES = {
    "spheres": ("testcases/shapes/drum_repose", "spheres.json", DRUM, "steps"),
    "dumbbells": ("testcases/shapes/drum_repose", "clumps.json", dict(DRUM, count=288, seed=1), "steps"),
    "rotating": ("testcases/scenes/drum", "scene.json", DRUM, "steps"),
    "hopper": ("testcases/scenes/hopper", "scene.json", dict(D_MM=20, N=6000, SEED=1), "STEPS"),
}


def run(build: Path, scene: str, steps: int, folder: Path) -> dict:
    """One run of a scene by a build in folder (a copy of the test case); timing.json of the run."""
    case, script, extra, steps_name = SCENES[scene]
    shutil.copytree(REPO / case, folder)
    values = dict(extra, **{steps_name: steps})
    command = [sys.executable, "-m", "engine", "-in", script, "-threads", "1"]
    for name, value in values.items():
        command += ["-var", name, str(value)]
    env = dict(os.environ, PYTHONPATH=str(build.resolve()))
    done = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{build} {scene}: exit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return json.loads((folder / "timing.json").read_text())


def outputs(folder: Path) -> list:
    """The files a run wrote that must not change: everything but the log and the timing."""
    return sorted(p.relative_to(folder) for p in folder.rglob("*")
                  if p.is_file() and p.suffix in (".csv", ".vtp", ".txt") and p.name != "stdout.txt")


def identical(a: Path, b: Path) -> bool:
    files = outputs(a)
    return files == outputs(b) and all(filecmp.cmp(a / f, b / f, shallow=False) for f in files)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--builds", type=Path, nargs="+", default=[REPO])
    parser.add_argument("--scenes", nargs="+", choices=tuple(SCENES), default=["spheres", "dumbbells"])
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="engine_drum_") as tmp:
        work = Path(tmp)
        results: dict = {}
        for scene in args.scenes:
            for b, build in enumerate(args.builds):  # a first run each, not timed: compiles or loads the kernels
                run(build, scene, 10, work / f"warm-{scene}-{b}")
            for r in range(args.repeat):
                for b, build in enumerate(args.builds):
                    folder = work / f"{scene}-{b}-{r}"
                    results.setdefault((scene, b), []).append((run(build, scene, args.steps, folder), folder))
        print(f"{args.steps} steps, one thread, median of {args.repeat}; phases per step (timing.json)")
        print(f"{'scene':10} {'build':28} {'us/step':>8} {'ns/p-step':>9} {'pair':>7} {'neigh':>7} {'modify':>7} "
              f"{'ratio':>6}  outputs")
        for scene in args.scenes:
            base = None
            for b, build in enumerate(args.builds):
                runs = results[(scene, b)]
                steps = runs[0][0]["steps"]
                total = statistics.median(t["total"] for t, _ in runs)
                per_particle = statistics.median(t["total"] / t["particle_steps"] for t, _ in runs)
                phases = [statistics.median(t[p] for t, _ in runs) / steps * 1e6 for p in ("pair", "neigh", "modify")]
                base = base or total
                same = "" if b == 0 else ("identical to the first build" if identical(results[(scene, 0)][0][1],
                                                                                       runs[0][1]) else "DIFFER")
                print(f"{scene:10} {str(build)[-28:]:28} {total / steps * 1e6:8.1f} {per_particle * 1e9:9.1f} "
                      f"{phases[0]:7.1f} {phases[1]:7.1f} {phases[2]:7.1f} {total / base:6.3f}  {same}")


if __name__ == "__main__":
    main()
