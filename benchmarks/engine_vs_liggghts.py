"""The settling scene in the bundled engine (1 and 2 threads) and LIGGGHTS 3.8 (1 and 2 MPI ranks), side by side.

The scene of engine/examples/settling.json and benchmarks/liggghts_settling.py (the same LIGGGHTS script):
N spheres (r = 1.5 mm) packed at random into a box of plane walls (half width 0.03 sqrt(N / 10000) m, packing
height 0.2 m), Hertz + tangential history, gravity, dt = 1e-5 s, STEPS steps. Each configuration runs as a
program directly (no harness): the engine with NUMBA_NUM_THREADS = T, LIGGGHTS with ``mpirun -np P`` and
``processors PX PY PZ``. Configurations alternate within each repetition, so that the load of a shared
machine hits all of them alike; figures are the median loop times (the engine's `Loop time` lines, LIGGGHTS'
`Loop time of` lines: stepping only, no start-up or compilation) and the ratios engine / LIGGGHTS. On a machine
other jobs load, wall times say little; the CPU seconds are printed too (the engine's loop, timing.json `cpu`;
LIGGGHTS' whole program including its start-up and insertion, all ranks: a ratio slightly in LIGGGHTS' favour).

    python benchmarks/engine_vs_liggghts.py                                  # N = 10000, 30000 steps
    python benchmarks/engine_vs_liggghts.py --steps 3000 --repeat 3          # quicker, while iterating
    python benchmarks/engine_vs_liggghts.py --grids 2x1x1 1x2x1              # LIGGGHTS' 2-rank grids
    python benchmarks/engine_vs_liggghts.py --engine /tmp/old                # another build of engine/
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from liggghts_settling import IN_SETTLING, LIGGGHTS  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # the harness' adapters read the logs
from harness.adapters import get_adapter  # noqa: E402
from harness.adapters.base import with_open_mpi_flags  # noqa: E402


def scene_variables(n: int, steps: int) -> dict:
    return dict(N=n, SEED=1, HALF_WIDTH=round(0.03 * math.sqrt(n / 10000), 6), HEIGHT=0.2, DUMP_EVERY=10 ** 9,
                SETTLE_STEPS=steps, MEASURE_STEPS=0)


def run_engine(engine: Path, folder: Path, variables: dict, threads: int) -> tuple[float, float]:
    """(loop seconds, CPU seconds of the loop) of one engine run."""
    folder.mkdir(parents=True)
    cmd = [sys.executable, "-m", "engine", "-in", str(engine / "engine" / "examples" / "settling.json"),
           "-log", "log.dem"] + [a for k, v in variables.items() for a in ("-var", k, str(v))]
    env = dict(os.environ, PYTHONPATH=str(engine), NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    proc = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(f"engine failed: {proc.stderr.strip()[-400:]}")
    loop = sum(block.seconds for block in get_adapter("dem").loop_blocks(folder))
    return loop, json.loads((folder / "timing.json").read_text())["cpu"]


def run_liggghts(folder: Path, variables: dict, grid: tuple[int, int, int]) -> tuple[float, float]:
    """(loop seconds, CPU seconds of the whole program, all ranks) of one LIGGGHTS run on prod(grid) ranks."""
    folder.mkdir(parents=True)
    script = IN_SETTLING.replace("region          domain block",
                                 "processors      {} {} {}\nregion          domain block".format(*grid), 1)
    (folder / "in.settling").write_text(script)
    ranks = grid[0] * grid[1] * grid[2]
    cmd = [LIGGGHTS, "-in", "in.settling", "-log", "log.liggghts", "-echo", "none"]  # -screen none crashes 3.8
    for k, v in variables.items():
        cmd += ["-var", k, str(v)]
    if ranks > 1:
        mpirun = shutil.which("mpirun") or "mpirun"
        cmd = with_open_mpi_flags([mpirun, "-np", str(ranks), "--bind-to", "none"]) + cmd
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen(cmd, cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    err = proc.stderr.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status):
        raise SystemExit(f"LIGGGHTS failed: {err.strip()[-400:]}")
    loop = sum(block.seconds for block in get_adapter("liggghts").loop_blocks(folder))
    return loop, usage.ru_utime + usage.ru_stime


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--particles", type=int, default=10000)
    parser.add_argument("--steps", type=int, default=30000)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="engine thread counts")
    parser.add_argument("--grids", nargs="*", default=["2x1x1"],
                        help="LIGGGHTS processor grids besides 1x1x1 (none: serial only)")
    parser.add_argument("--engine", type=Path, default=REPO, help="folder holding engine/ (default: this checkout)")
    args = parser.parse_args()
    variables = scene_variables(args.particles, args.steps)
    configs = [(f"engine {t} thread{'s' if t > 1 else ''}", "engine", t) for t in args.threads]
    grids = [(1, 1, 1)] + [tuple(int(a) for a in g.split("x")) for g in args.grids]
    configs += [(f"LIGGGHTS {g[0]}x{g[1]}x{g[2]}", "liggghts", g) for g in grids]
    times = {label: [] for label, _, _ in configs}
    cpu = {label: [] for label, _, _ in configs}
    with tempfile.TemporaryDirectory(prefix="engine-vs-liggghts-") as tmp:
        # one untimed engine run per thread count first: compiles the kernels (not part of any figure)
        for t in args.threads:
            run_engine(args.engine, Path(tmp) / f"warm{t}", dict(variables, SETTLE_STEPS=1), t)
        for r in range(args.repeat):
            for k, (label, code, what) in enumerate(configs):
                folder = Path(tmp) / f"{r}-{k}"
                seconds, cpu_seconds = (run_engine(args.engine, folder, variables, what) if code == "engine"
                                        else run_liggghts(folder, variables, what))
                times[label].append(seconds)
                cpu[label].append(cpu_seconds)
                print(f"  repetition {r + 1}: {label:<22} {seconds:8.2f} s (cpu {cpu_seconds:.2f} s)", flush=True)
    median = {label: statistics.median(v) for label, v in times.items()}
    print(f"settling scene, {args.particles} spheres, {args.steps} steps; median loop time of {args.repeat} "
          f"repetition(s)")
    median_cpu = {label: statistics.median(v) for label, v in cpu.items()}
    for label, seconds in median.items():
        print(f"{label:<22} {seconds:8.2f} s  {args.particles * args.steps / seconds:10.3e} particle-steps/s  "
              f"cpu {median_cpu[label]:.2f} s")
    serial = median["LIGGGHTS 1x1x1"]
    parallel = {label: s for label, s in median.items() if label.startswith("LIGGGHTS") and label != "LIGGGHTS 1x1x1"}
    best = min(parallel, key=parallel.get) if parallel else None
    for t in args.threads:
        label = f"engine {t} thread{'s' if t > 1 else ''}"
        line = (f"{label}: / serial LIGGGHTS {median[label] / serial:.2f} (cpu "
                f"{median_cpu[label] / median_cpu['LIGGGHTS 1x1x1']:.2f})")
        if t > 1 and best:
            line += f", / {best} {median[label] / parallel[best]:.2f}"
        print(line)


if __name__ == "__main__":
    main()
