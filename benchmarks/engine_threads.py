"""Stepping speed of engine builds and thread counts side by side on the settling scene (issue 11).

The scene of engine/examples/settling_box.json (settling.json with the domain as wide as the walls, so that
no sphere is lost at 100,000 and more: N spheres of r = 1.5 mm packed at random into a box of five plane
walls, Hertz + tangential history, gravity, dt = 1e-5 s): SETTLE steps of pouring and settling, then MEASURE
steps on the bed. Each (build, threads) configuration runs the same scene; configurations alternate within
each repetition so that the machine's load hits all of them alike. A build is a folder holding engine/ (an
old commit: `git archive <commit> engine | tar -x -C /tmp/old`). Figures are the engine's own loop times
(the `Loop time` lines: stepping without start-up or compilation), the median over repetitions, and their
ratios to the first configuration.

    python benchmarks/engine_threads.py --builds /tmp/old . --threads 1 2        # old (serial) vs new, 1 and 2
    python benchmarks/engine_threads.py --sizes 10000 100000 --settle 30000 --measure 2000 --repeat 3

A build that has no threads runs once per repetition whatever --threads says (its loops are serial).
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "engine" / "examples" / "settling_box.json"
RADIUS = 0.0015  # m, as in the scene
sys.path.insert(0, str(REPO))  # the harness' adapters read the logs
from harness.adapters import get_adapter  # noqa: E402


def variables(n: int, settle: int, measure: int) -> dict:
    """Box half width 0.03 sqrt(N / 10000) m (the same bed height for every N), packed at solid fraction 0.28."""
    half_width = 0.03 * math.sqrt(n / 10000)
    usable = (2 * half_width - 2 * RADIUS) ** 2
    height = n * 4 / 3 * math.pi * RADIUS ** 3 / (0.28 * usable) + 2 * RADIUS
    return dict(N=n, SEED=1, HALF_WIDTH=half_width, HEIGHT=height, DUMP_EVERY=10 ** 9, SETTLE_STEPS=settle,
                MEASURE_STEPS=measure)


def threaded(build: Path) -> bool:
    return (build / "engine" / "threads.py").exists()


def run(build: Path, threads: int, values: dict) -> tuple[float, float]:
    """(settle loop time, measure loop time) in s of one engine run."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "engine", "-in", str(SCENE), "-log", "log.dem"]
        for k, v in values.items():
            cmd += ["-var", k, str(v)]
        env = dict(os.environ, PYTHONPATH=str(build.resolve()), NUMBA_NUM_THREADS=str(threads))
        proc = subprocess.run(cmd, cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if proc.returncode:
            raise SystemExit(f"{build} ({threads} threads): engine failed: {proc.stderr.strip()[-500:]}")
        loops = get_adapter("dem").loop_blocks(Path(tmp))
        return loops[0].seconds, loops[1].seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--builds", type=Path, nargs="+", default=[REPO])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10000])
    parser.add_argument("--settle", type=int, default=30000)
    parser.add_argument("--measure", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    configs = [(b, t) for b in args.builds for t in (args.threads if threaded(b) else args.threads[:1])]
    for build in args.builds:  # compile (or load) every kernel once, outside the figures
        run(build, 1, variables(1000, 10, 10))
    for n in args.sizes:
        values = variables(n, args.settle, args.measure)
        times = {c: [] for c in configs}
        for rep in range(args.repeat):
            order = configs if rep % 2 == 0 else configs[::-1]
            for config in order:
                settle, measure = run(*config, values)
                times[config].append((settle, measure))
                print(f"N={n} rep {rep + 1}: {config[0]} threads {config[1]}: settle {settle:.2f} s, "
                      f"measure {measure:.2f} s", flush=True)
        print(f"\nN = {n}: {args.settle} + {args.measure} steps, median of {args.repeat} (loop times)")
        print(f"{'build':<28} {'threads':>7} {'settle (s)':>11} {'measure (s)':>12} {'total (s)':>10} "
              f"{'first/this':>10} {'Mps/s':>7}")
        first = None
        for config in configs:
            settle = statistics.median(t[0] for t in times[config])
            measure = statistics.median(t[1] for t in times[config])
            total = settle + measure
            first = first or total
            rate = n * (args.settle + args.measure) / total / 1e6
            print(f"{str(config[0]):<28} {config[1]:>7} {settle:>11.2f} {measure:>12.2f} {total:>10.2f} "
                  f"{first / total:>10.2f} {rate:>7.2f}")


if __name__ == "__main__":
    main()
