"""Peak memory of the bundled engine per particle count, for one or two builds side by side (issue 11).

The settling scene (engine/examples/settling_box.json, settling.json with the domain as wide as the walls: spheres of r = 1.5 mm packed at random into a box of five
plane walls at solid fraction 0.28, Hertz + tangential history, gravity) with N particles, run for STEPS steps;
the figure is the peak resident memory of the engine process (os.wait4 rusage, ru_maxrss) and, above the
1-particle run of the same build, the bytes per particle ((RSS(N) - RSS(1)) / N). The scene writes one VTK
dump at step 0, so every run loads VTK. A build is a folder holding
engine/ (e.g. an old commit exported with `git archive <commit> engine | tar -x -C /tmp/old`); builds run
alternately for each N.

    python benchmarks/engine_memory.py                                  # this checkout, N = 1, 1e4, 1e5
    python benchmarks/engine_memory.py --builds /tmp/old . --sizes 1 10000 100000 1000000
"""
from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "engine" / "examples" / "settling_box.json"
RADIUS = 0.0015  # m, as in the scene


def scene_variables(n: int, steps: int) -> dict:
    """Box half width 0.03 sqrt(N / 10000) m (at least 5 radii), filled to solid fraction 0.28."""
    half_width = max(0.03 * math.sqrt(n / 10000), 5 * RADIUS)
    usable = (2 * half_width - 2 * RADIUS) ** 2
    height = max(n * 4 / 3 * math.pi * RADIUS ** 3 / (0.28 * usable) + 2 * RADIUS, 4 * RADIUS)
    return dict(N=n, SEED=1, HALF_WIDTH=half_width, HEIGHT=height, DUMP_EVERY=10 ** 9,
                SETTLE_STEPS=steps, MEASURE_STEPS=0)


def peak_rss(build: Path, n: int, steps: int, threads: int | None) -> int:
    """Peak RSS (bytes) of one engine run."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "engine", "-in", str(SCENE), "-log", "log.dem"]
        for k, v in scene_variables(n, steps).items():
            cmd += ["-var", k, str(v)]
        env = dict(os.environ, PYTHONPATH=str(build.resolve()))
        if threads:
            env["NUMBA_NUM_THREADS"] = str(threads)
        proc = subprocess.Popen(cmd, cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(proc.pid, 0)
        err = proc.stderr.read().decode()
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"{build} N={n}: engine failed: {err.strip()[-500:]}")
        return usage.ru_maxrss * 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--builds", type=Path, nargs="+", default=[REPO])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 10000, 100000])
    parser.add_argument("--steps", type=int, default=200, help="steps per run (the first rebuilds included)")
    parser.add_argument("--threads", type=int, help="NUMBA_NUM_THREADS")
    args = parser.parse_args()
    sizes = sorted(set(args.sizes) | {1})
    rss = {b: {} for b in args.builds}
    for build in args.builds:  # compile (or load) the kernels of both thread modes first: compiling holds
        for n in (1, 5000):    # LLVM's memory, which is not what this measures
            peak_rss(build, n, 10, args.threads)
    print(f"{'build':<28} {'N':>8} {'peak RSS (MB)':>14} {'B/particle above N=1':>21}")
    for n in sizes:
        for build in args.builds:
            rss[build][n] = peak_rss(build, n, args.steps, args.threads)
            base = rss[build][1]
            per = (rss[build][n] - base) / n if n > 1 else float("nan")
            print(f"{str(build):<28} {n:>8} {rss[build][n] / 1e6:>14.1f} {per:>21.0f}", flush=True)


if __name__ == "__main__":
    main()
