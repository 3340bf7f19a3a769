"""The issue-12 scenes side by side with LIGGGHTS: loop time of the bundled engine over LIGGGHTS' (issue 12).

For each scene folder named (default: testcases/scenes/drum and testcases/scenes/hopper when it has LIGGGHTS
runs) the script takes the runs of its run.config that name a script for both codes
(``"script": {"dem": ..., "liggghts": ...}``), with their variables, and runs each in both codes, one run at a
time and alternating (engine, LIGGGHTS, engine, LIGGGHTS, ... for ``--repeats`` rounds), so that a change of
the machine's load falls on both codes alike. Each run gets a fresh copy of the scene folder under a temporary
folder, the way the harness prepares a run folder (the codes read ``meshes/`` relative to it). The times are
read from the codes' own logs through the harness adapters:

- loop s: LIGGGHTS' ``Loop time of T`` (summed over run blocks), the engine's timing.json ``total`` (the
  stepping loop without start-up and JIT compilation);
- wall s: the whole program (for the engine with Python start-up and, on the first run, compilation);
- particle-steps/s: the engine's own count (timing.json), for LIGGGHTS atoms x steps of the last thermo row
  (the drum keeps its particles; a scene with insertion or outlets counts the end's particles: a bound).

Printed: one line per run, then per scene run the median loop times and their ratio engine / LIGGGHTS.

    python benchmarks/scenes_vs_liggghts.py                                  # drum (+ hopper), 2 rounds
    python benchmarks/scenes_vs_liggghts.py --scenes testcases/scenes/drum --repeats 3 --var steps 50000
    python benchmarks/scenes_vs_liggghts.py --scenes testcases/shapes/drum_repose -k dumbbells_2 --var steps 100000
                                                                             # clumps: LIGGGHTS' multisphere model
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
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from harness.adapters import get_adapter  # noqa: E402

LIGGGHTS = shutil.which("liggghts") or "/usr/bin/liggghts"
DEFAULT_SCENES = ["testcases/scenes/drum", "testcases/scenes/hopper"]
#: what the harness leaves out of a run folder copy (harness README: the folder without post/)
NOT_COPIED = {"post", "__pycache__", "run.config"}


def paired_runs(folder: Path) -> list[dict]:
    """Runs of the scene's run.config with a script for the engine and for LIGGGHTS."""
    config = folder / "run.config"
    if not config.is_file():
        return []
    runs = json.loads(config.read_text()).get("runs", [])
    return [run for run in runs if isinstance(run.get("script"), dict)
            and "dem" in run["script"] and "liggghts" in run["script"]]


def prepare(scene: Path, folder: Path) -> None:
    shutil.copytree(scene, folder, ignore=lambda _d, names: [n for n in names if n in NOT_COPIED])
    (folder / "post").mkdir(exist_ok=True)


def command(code: str, script: str, variables: dict) -> list[str]:
    executable = [sys.executable, "-m", "engine"] if code == "dem" else [LIGGGHTS]
    return get_adapter(code).command(executable, script, {k: str(v) for k, v in variables.items()},
                                     get_adapter(code).log_file())


def run_once(code: str, scene: Path, run: dict, variables: dict, folder: Path) -> dict:
    prepare(scene, folder)
    env = dict(os.environ, PYTHONPATH=str(REPO))
    start = time.perf_counter()
    result = subprocess.run(command(code, run["script"][code], variables), cwd=folder, env=env,
                            capture_output=True, text=True)
    wall = time.perf_counter() - start
    adapter = get_adapter(code)
    if result.returncode != 0 or adapter.scan_log(folder).errors:
        errors = adapter.scan_log(folder).errors or [result.stderr.strip()[-200:]]
        return {"code": code, "failed": errors[0]}
    timing = adapter.read_timing(folder)
    thermo = adapter.read_thermo(folder)
    steps = int(thermo["step"].iloc[-1] - thermo["step"].iloc[0])
    particle_steps = timing.get("particle_steps") or float(thermo["atoms"].iloc[-1]) * steps
    return {"code": code, "loop": timing["total"], "wall": wall, "steps": steps,
            "atoms": int(thermo["atoms"].iloc[-1]), "rate": particle_steps / timing["total"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", nargs="+", default=DEFAULT_SCENES, help="scene folders (relative to the repository)")
    parser.add_argument("--repeats", type=int, default=2, help="rounds of engine + LIGGGHTS per run")
    parser.add_argument("--var", nargs=2, action="append", default=[], metavar=("NAME", "VALUE"),
                        help="override a run variable (e.g. --var steps 50000)")
    parser.add_argument("-k", dest="pattern", default="", help="only runs whose name contains this")
    args = parser.parse_args()
    overrides = dict(args.var)
    print(f"engine: python -m engine of {REPO}; LIGGGHTS: {LIGGGHTS}; serial runs, one at a time, alternating; "
          f"load average at start {os.getloadavg()[0]:.2f}")
    print(f"{'scene/run':<24} {'round':>5} {'code':>9} {'atoms':>6} {'steps':>7} {'loop s':>8} {'wall s':>8} "
          f"{'p-steps/s':>10}")
    summary = []
    with tempfile.TemporaryDirectory(prefix="scenes-bench-") as tmp:
        for scene_name in args.scenes:
            scene = (REPO / scene_name).resolve()
            runs = [r for r in paired_runs(scene) if args.pattern in r["name"]]
            if not runs:
                print(f"{scene_name}: no run with both a 'dem' and a 'liggghts' script, skipped")
                continue
            for run in runs:
                variables = {**run.get("variables", {}), **overrides}
                label = f"{scene.name}/{run['name']}"
                loops = {"dem": [], "liggghts": []}
                for round_ in range(args.repeats):
                    for code in ("dem", "liggghts"):
                        folder = Path(tmp) / f"{scene.name}-{run['name']}-{code}-{round_}"
                        result = run_once(code, scene, run, variables, folder)
                        if "failed" in result:
                            print(f"{label:<24} {round_:>5} {code:>9} failed: {result['failed'][:100]}", flush=True)
                            continue
                        loops[code].append(result["loop"])
                        print(f"{label:<24} {round_:>5} {code:>9} {result['atoms']:>6} {result['steps']:>7} "
                              f"{result['loop']:>8.2f} {result['wall']:>8.2f} {result['rate']:>10.3e}", flush=True)
                        shutil.rmtree(folder, ignore_errors=True)
                if loops["dem"] and loops["liggghts"]:
                    summary.append((label, statistics.median(loops["dem"]), statistics.median(loops["liggghts"])))
    print()
    print(f"{'scene/run':<24} {'engine loop s':>13} {'LIGGGHTS loop s':>15} {'engine / LIGGGHTS':>17}  (medians)")
    for label, dem, liggghts in summary:
        print(f"{label:<24} {dem:>13.2f} {liggghts:>15.2f} {dem / liggghts:>17.2f}")


if __name__ == "__main__":
    main()
