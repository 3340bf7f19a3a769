"""The engine at two revisions on the settled bed of the settling scene, one thread, side by side.

    python benchmarks/engine_particle_pass.py [--base main] [--new worktree] [--n 10000] [--steps 2000] [--repeat 3]

The settling scene (engine/examples/settling.json, N spheres, six planes, Hertz + tangential history, gravity)
is poured and settled for 8,000 steps by the new engine and written to a restart file; both engines then
continue it for STEPS steps, alternating within each repetition (so that the load of a shared machine hits both
alike). Printed per run: the loop's CPU seconds (timing.json `cpu`) and the phase timers (wall clock) in ns per
particle-step, then the median CPU ratio new / base and whether the thermo files of the two are byte-identical.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from engine_identical import REPO, export_engine  # noqa: E402

SKIP = ("domain", "random_packing", "wall")


def scripts(folder: Path):
    """make.json (settle, write bed.restart) and measure.json (read it, run STEPS) from the example scene."""
    scene = json.loads((REPO / "engine" / "examples" / "settling.json").read_text())
    setup = [c for c in scene if c["command"] not in ("run", "unfix") and c.get("kind") != "vtk"
             and not (c["command"] == "fix" and c["name"] == "dump")]
    make = setup + [{"command": "run", "steps": 8000}, {"command": "create", "object": "restart", "file": "bed.restart"}]
    measure = [c for c in setup if c.get("object") not in SKIP]
    first_modifier = next(k for k, c in enumerate(measure) if c.get("object") == "modifier")
    measure.insert(first_modifier, {"command": "set", "property": "restart", "file": "bed.restart"})
    measure.append({"command": "run", "steps": "${STEPS}"})
    (folder / "make.json").write_text(json.dumps(make))
    (folder / "measure.json").write_text(json.dumps(measure))


def run(engine: Path, folder: Path, script: str, variables: dict) -> dict:
    command = [sys.executable, "-m", "engine", "-in", script, "-log", "log.dem", "-threads", "1"]
    for name, value in variables.items():
        command += ["-var", name, str(value)]
    env = {**os.environ, "PYTHONPATH": str(engine), "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(f"engine failed in {folder}: {proc.stdout.strip()[-400:]}")
    return json.loads((folder / "timing.json").read_text())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main")
    parser.add_argument("--new", default="worktree")
    parser.add_argument("--n", type=int, default=10000)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="engine_pass_") as tmp:
        root = Path(tmp)
        engines = {side: export_engine(rev, root / f"engine_{side}") for side, rev in
                   (("base", args.base), ("new", args.new))}
        scripts(root)
        half_width = round(0.03 * (args.n / 10000) ** 0.5, 6)
        run(engines["new"], root, "make.json", dict(N=args.n, SEED=1, HALF_WIDTH=half_width, HEIGHT=0.2))
        cpu = {"base": [], "new": []}
        thermo = {}
        for rep in range(args.repeat + 1):  # repetition 0 compiles (or loads) the kernels: not counted
            for side in ("base", "new"):
                folder = root / f"{side}{rep}"
                folder.mkdir()
                for name in ("measure.json", "bed.restart"):
                    shutil.copy(root / name, folder / name)
                t = run(engines[side], folder, "measure.json", dict(STEPS=args.steps))
                thermo[side] = (folder / "thermo.csv").read_bytes()
                if rep == 0:
                    continue
                per = 1e9 / t["particle_steps"]
                cpu[side].append(t["cpu"])
                print(f"{side:4} ({args.base if side == 'base' else args.new}): cpu {t['cpu'] * per:6.1f} ns per "
                      f"particle-step; wall: pair {t['pair'] * per:5.1f}, neigh {t['neigh'] * per:5.1f}, "
                      f"modify {t['modify'] * per:5.1f}", flush=True)
        ratio = statistics.median(cpu["new"]) / statistics.median(cpu["base"])
        print(f"CPU new / base: {ratio:.3f} (median of {args.repeat}); thermo identical: "
              f"{thermo['base'] == thermo['new']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
