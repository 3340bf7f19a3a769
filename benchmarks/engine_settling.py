"""Speed and memory of the bundled engine on the settling scene (issue 2).

N spheres (r = 1.5 mm) are packed at random into a box of plane walls and settle under gravity: Hertz +
tangential history, Y = 5e6 Pa, nu = 0.45, e = 0.5, mu = 0.3, rho = 2500 kg/m^3, dt = 1e-5 s. The scene is
engine/examples/settling.json. After SETTLE steps (bed formed) the engine runs MEASURE more steps; the
figure is the particle-steps per second of that second run (from the engine's log: per wall-clock second and
per CPU second of the loop), and the peak resident memory of the engine process (os.wait4 rusage).

    python benchmarks/engine_settling.py                 # N = 1000 and 10000
    python benchmarks/engine_settling.py --sizes 10000 --settle 30000 --measure 2000
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "engine" / "examples" / "settling.json"
RADIUS = 0.0015  # m, as in the scene
sys.path.insert(0, str(REPO))  # the harness' adapters read the logs
from harness.adapters import get_adapter  # noqa: E402


def run_engine(folder: Path, variables: dict) -> int:
    """Run the engine as a program in ``folder``; returns its peak RSS in kB."""
    cmd = [sys.executable, "-m", "engine", "-in", str(SCENE), "-log", "log.dem"]
    for k, v in variables.items():
        cmd += ["-var", k, str(v)]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen(cmd, cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    err = proc.stderr.read().decode()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"engine failed: {err.strip()}")
    return usage.ru_maxrss


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--settle", type=int, default=30000, help="steps until the bed has formed")
    parser.add_argument("--measure", type=int, default=2000, help="steps timed on the settled bed")
    args = parser.parse_args()
    print("particle-steps per second of wall time (and per CPU second: the figure that does not depend on what")
    print("else runs on the machine)")
    print(f"{'N':>7} {'pour+settle':>11} {'settled bed':>11} {'settled, CPU':>12} {'contacts':>9} {'ke end (J)':>11} "
          f"{'peak RSS (MB)':>14}")
    for n in args.sizes:
        half_width = 0.03 * math.sqrt(n / 10000)  # same bed height (about 6.5 cm) for every N
        # pour from a random packing at volume fraction 0.28 of the space the centres can reach
        usable = (2 * half_width - 2 * RADIUS) ** 2
        height = n * 4 / 3 * math.pi * RADIUS ** 3 / (0.28 * usable) + 2 * RADIUS
        with tempfile.TemporaryDirectory() as tmp:
            rss_kb = run_engine(Path(tmp), dict(N=n, SEED=1, HALF_WIDTH=half_width, HEIGHT=height,
                                                     DUMP_EVERY=10 ** 9, SETTLE_STEPS=args.settle,
                                                     MEASURE_STEPS=args.measure))
            loops = get_adapter("dem").loop_blocks(Path(tmp))
            with open(Path(tmp) / "thermo.csv") as handle:
                last = list(csv.DictReader(handle))[-1]
        settle_rate, settled_rate, settled_cpu = loops[0].rate, loops[1].rate, loops[1].cpu_rate
        print(f"{n:>7} {settle_rate:>11.3e} {settled_rate:>11.3e} {settled_cpu:>12.3e} {last['contacts']:>9} "
              f"{float(last['ke']):>11.3e} {rss_kb / 1024:>14.1f}", flush=True)


if __name__ == "__main__":
    main()
