"""What compilation costs: the dem runs of testcases/ with an empty kernel cache, then again with a warm one.

For each build (a folder holding engine/), engine/ is copied without its __pycache__ into a temporary folder
and DEM_CACHE_DIR points to an empty folder, as for a freshly built target of the harness; every dem run of the
collection (sweeps expanded, chains in one folder) runs one after the other, then all again. Reported: wall
time of the whole pass (processes included), the part the engine reports as compilation (timing.json
`compile`), and cold/warm; the CPU seconds of the engine processes of each pass and their difference, the
compilation's CPU seconds (what a loaded machine changes least: compiling is one thread's work). Also the wall
time of a warm 1-particle run (start-up).

    python benchmarks/engine_coldstart.py /tmp/old .
    python benchmarks/engine_coldstart.py . -k crosscode      # runs whose label contains 'crosscode'
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from engine_versions import REPO, dem_runs  # noqa: E402

ONE_PARTICLE = [
    {"command": "create", "object": "domain", "lo": [-1, -1, -1], "hi": [1, 1, 1]},
    {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.45,
     "density": 2500},
    {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3},
    {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
    {"command": "create", "object": "particle", "type": 1, "radius": 0.01, "position": [0, 0, 0.5]},
    {"command": "set", "property": "timestep", "value": 1e-5},
    {"command": "run", "steps": 100}]


def children_cpu() -> float:
    """CPU seconds (user + system) of the finished child processes of this one so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def collection_pass(src: Path, cache: Path, work: Path, match: str | None = None) -> tuple[float, float, float]:
    """(wall seconds, compile seconds, CPU seconds) of every dem run of the collection (whose label contains
    match)."""
    env = dict(os.environ, PYTHONPATH=str(src), DEM_CACHE_DIR=str(cache))
    wall = compile_time = 0.0
    cpu0 = children_cpu()
    for index, (_, case, steps) in enumerate(dem_runs(REPO / "testcases", match)):
        folder = work / str(index)
        shutil.copytree(case, folder)
        for k, (script, variables) in enumerate(steps):
            args = [a for name, value in variables.items() for a in ("-var", name, str(value))]
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "engine", "-in", script, "-log", f"log{k}.dem", *args],
                           cwd=folder, env=env, capture_output=True)
            wall += time.perf_counter() - t0
            if (folder / "timing.json").exists():
                compile_time += json.loads((folder / "timing.json").read_text()).get("compile", 0.0)
        shutil.rmtree(folder)
    return wall, compile_time, children_cpu() - cpu0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("builds", type=Path, nargs="+")
    parser.add_argument("-k", dest="match", help="only runs whose label contains this text")
    args = parser.parse_args()
    print(f"{'build':<28} {'cold (s)':>9} {'compile':>8} {'warm (s)':>9} {'compile':>8} {'cold/warm':>9} "
          f"{'1 particle (s)':>14} {'cold CPU':>9} {'warm CPU':>9} {'compile CPU':>11}")
    for build in args.builds:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            shutil.copytree(build / "engine", tmp / "src" / "engine", ignore=shutil.ignore_patterns("__pycache__"))
            cold, cold_compile, cold_cpu = collection_pass(tmp / "src", tmp / "cache", tmp / "work", args.match)
            warm, warm_compile, warm_cpu = collection_pass(tmp / "src", tmp / "cache", tmp / "work", args.match)
            (tmp / "one").mkdir()
            (tmp / "one" / "scene.json").write_text(json.dumps(ONE_PARTICLE))
            env = dict(os.environ, PYTHONPATH=str(tmp / "src"), DEM_CACHE_DIR=str(tmp / "cache"))
            starts = []
            for _ in range(3):
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=tmp / "one", env=env,
                               capture_output=True)
                starts.append(time.perf_counter() - t0)
        print(f"{str(build):<28} {cold:>9.1f} {cold_compile:>8.1f} {warm:>9.1f} {warm_compile:>8.1f} "
              f"{cold / warm:>9.2f} {min(starts):>14.2f} {cold_cpu:>9.1f} {warm_cpu:>9.1f} "
              f"{cold_cpu - warm_cpu:>11.1f}", flush=True)


if __name__ == "__main__":
    main()
