"""Stepping speed of engine builds and thread counts side by side on the settling scene (issue 11).

The scene of engine/examples/settling_box.json (settling.json with the domain as wide as the walls, so that
no sphere is lost at 100,000 and more: N spheres of r = 1.5 mm packed at random into a box of five plane
walls, Hertz + tangential history, gravity, dt = 1e-5 s): SETTLE steps of pouring and settling, then MEASURE
steps on the bed. Each (build, threads) configuration runs the same scene; configurations alternate within
each repetition, and the sizes take turns in it, so that the machine's load hits all of them alike. A build is
a folder holding engine/ (an old commit: `git archive <commit> engine | tar -x -C /tmp/old`). Figures are the
engine's own loop times (the `Loop time` lines: stepping without start-up or compilation), the median over
repetitions, and their ratios to the first configuration.

    python benchmarks/engine_threads.py --builds /tmp/old . --threads 1 2        # old (serial) vs new, 1 and 2
    python benchmarks/engine_threads.py --sizes 10000 100000 --settle 30000 --measure 2000 --repeat 3

A build that has no threads runs once per repetition whatever --threads says (its loops are serial).

Two figures per configuration: the rate over both runs (settle + measure, the figure of issue 11) and the
steady-state rate of the measure run alone. The first flatters large N: a short settle run is mostly the
loop's start-up and first rebuild, which cost about the same per particle at every N. With several sizes the
ratios of each rate to the first size's rate are printed too (e.g. 1,000,000 against 10,000: the cost of
particles that no longer fit in cache). With --scene bed the scene is a dense bed instead (below): every
sphere in contact from the first step, so pairs in contact and their history are in the figure; in the
settling scene's first hundreds of steps the spheres fall freely and no pair touches.

    python benchmarks/engine_threads.py --builds . --threads 2 --sizes 10000 1000000 --settle 10 --measure 500
    python benchmarks/engine_threads.py --scene bed --threads 2 --sizes 10000 1000000 --settle 10 --measure 500

At 10,000 the 500 steps take about 0.2 s, and their rate moves by 10-20 % from run to run: --small-repeat 7 runs
the sizes below 100,000 seven times (the median is the figure) while 1,000,000 runs --repeat times.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
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

#: the phases of an engine `Loop time` line (engine/runner.py _report)
PHASES = re.compile(r"Loop time of .*?; pair ([0-9.eE+-]+) s, neigh ([0-9.eE+-]+) s \(([0-9]+) rebuilds\), "
                    r"modify ([0-9.eE+-]+) s")


def variables(n: int, settle: int, measure: int) -> dict:
    """Box half width 0.03 sqrt(N / 10000) m (the same bed height for every N), packed at solid fraction 0.28."""
    half_width = 0.03 * math.sqrt(n / 10000)
    usable = (2 * half_width - 2 * RADIUS) ** 2
    height = n * 4 / 3 * math.pi * RADIUS ** 3 / (0.28 * usable) + 2 * RADIUS
    return dict(N=n, SEED=1, HALF_WIDTH=half_width, HEIGHT=height, DUMP_EVERY=10 ** 9, SETTLE_STEPS=settle,
                MEASURE_STEPS=measure)


def bed_scene(n: int) -> list:
    """A dense bed of about n spheres (r = 1.5 mm, the settling scene's material and contact model): a simple
    cubic lattice 10 layers high, square in x-y, each sphere overlapping its six neighbours (and the walls of a
    box of five planes around the lattice) by 0.1 um, with gravity. The overlaps hold it in place (the contact
    forces stay far below the weight, which compresses each column by about 10 um at the bottom), so every
    sphere is in contact from step 0, its contacts and their history in the pair loop, and few rebuilds."""
    overlap, layers = 1e-7, 10
    spacing = 2 * RADIUS - overlap
    side = max(1, round(math.sqrt(n / layers)))
    # lattice_points puts sites at lo + spacing/2 + k spacing and keeps the spheres entirely inside the region:
    # the first site of each axis sticks out by overlap/2 and is dropped, so the region holds one site more
    # (and 2 overlaps to spare at the far end); the kept sites are k = 1 ... side, centred on x = y = 0
    lo = [-(side + 2) * spacing / 2] * 2 + [RADIUS - 1.5 * spacing]
    hi = [lo[0] + (side + 1) * spacing + 2 * overlap] * 2 + [lo[2] + (layers + 1) * spacing + 2 * overlap]
    first = [lo[a] + 1.5 * spacing for a in range(3)]  # the outer centres: first and last along each axis
    last = [lo[0] + (side + 0.5) * spacing] * 2
    planes = [("floor", "z", first[2] - RADIUS + overlap), ("left", "x", first[0] - RADIUS + overlap),
              ("right", "x", last[0] + RADIUS - overlap), ("front", "y", first[1] - RADIUS + overlap),
              ("back", "y", last[1] + RADIUS - overlap)]
    return [
        {"command": "create", "object": "domain", "lo": [lo[0] - 0.01, lo[1] - 0.01, -0.01],
         "hi": [hi[0] + 0.01, hi[1] + 0.01, hi[2] + 0.05]},
        {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.45,
         "density": 2500},
        {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3},
        {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
        *({"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis, "position": pos,
           "type": 1} for name, axis, pos in planes),
        {"command": "create", "object": "lattice", "type": 1, "radius": RADIUS, "spacing": spacing,
         "region": {"shape": "box", "lo": lo, "hi": hi}},
        {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity",
         "acceleration": [0, 0, -9.81]},
        {"command": "fix", "name": "gravity"},
        {"command": "set", "property": "timestep", "value": 1e-5},
        {"command": "set", "property": "thermo", "every": 1000, "columns": ["contacts", "max_overlap"]},
        {"command": "run", "steps": "${SETTLE_STEPS}"},
        {"command": "run", "steps": "${MEASURE_STEPS}"},
    ]


def particles(scene: str, n: int) -> int:
    """The particles of the scene at size n (the bed rounds n to whole layers of a square lattice)."""
    return n if scene == "settling" else 10 * max(1, round(math.sqrt(n / 10))) ** 2


def threaded(build: Path) -> bool:
    return (build / "engine" / "threads.py").exists()


def run(build: Path, threads: int, values: dict, scene: str = "settling") -> tuple[float, float, list]:
    """(settle loop time, measure loop time, [pair, neigh, rebuilds, modify, particle-steps per CPU second] of
    the measure run) of one engine run; times in s."""
    with tempfile.TemporaryDirectory() as tmp:
        script = SCENE
        if scene == "bed":
            script = Path(tmp) / "bed.json"
            script.write_text(json.dumps(bed_scene(values["N"])))
        cmd = [sys.executable, "-m", "engine", "-in", str(script), "-log", "log.dem"]
        for k, v in values.items():
            cmd += ["-var", k, str(v)]
        env = dict(os.environ, PYTHONPATH=str(build.resolve()), NUMBA_NUM_THREADS=str(threads))
        proc = subprocess.run(cmd, cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if proc.returncode:
            raise SystemExit(f"{build} ({threads} threads): engine failed: {proc.stderr.strip()[-500:]}")
        loops = get_adapter("dem").loop_blocks(Path(tmp))
        phases = PHASES.findall((Path(tmp) / "log.dem").read_text())
        measured = [float(x) for x in phases[1]] if len(phases) > 1 else [math.nan] * 4
        measured.append(loops[1].cpu_rate or math.nan)
        return loops[0].seconds, loops[1].seconds, measured


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--builds", type=Path, nargs="+", default=[REPO])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10000])
    parser.add_argument("--settle", type=int, default=30000)
    parser.add_argument("--measure", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--small-repeat", type=int, default=None,
                        help="repetitions of sizes below 100,000 (default: --repeat): 500 steps of 10,000 spheres "
                             "take 0.2 s, whose rate moves by 10-20 %% from run to run")
    parser.add_argument("--scene", choices=("settling", "bed"), default="settling",
                        help="settling: engine/examples/settling_box.json; bed: a dense lattice bed (bed_scene)")
    args = parser.parse_args()
    configs = [(b, t) for b in args.builds for t in (args.threads if threaded(b) else args.threads[:1])]
    for build in args.builds:  # compile (or load) every kernel once, outside the figures
        run(build, 1, variables(1000, 10, 10), args.scene)
    rates = {c: {} for c in configs}  # config -> n -> (total rate, measure rate) in particle-steps/s
    sizes = [particles(args.scene, size) for size in args.sizes]
    repeats = {n: args.small_repeat if args.small_repeat and n < 100000 else args.repeat for n in sizes}
    times = {n: {c: [] for c in configs} for n in sizes}
    # the sizes take turns within each repetition, and the configurations within each size: the ratio between
    # sizes is the figure, and a machine whose speed drifts over minutes (shared cores) moves both its terms
    for rep in range(max(repeats.values())):
        for n in sizes:
            if rep >= repeats[n]:
                continue
            values = variables(n, args.settle, args.measure)
            for config in configs if rep % 2 == 0 else configs[::-1]:
                settle, measure, phases = run(*config, values, args.scene)
                times[n][config].append((settle, measure, phases))
                print(f"N={n} rep {rep + 1}: {config[0]} threads {config[1]}: settle {settle:.2f} s, "
                      f"measure {measure:.2f} s", flush=True)
    for n in sizes:
        print(f"\nN = {n} ({args.scene}): {args.settle} + {args.measure} steps, median of {repeats[n]} (loop "
              f"times); steady = the measure run alone; ns = per particle-step of the measure run; per cpu s = "
              f"over the process' CPU time (robust to a loaded machine on one thread; on several it counts "
              f"threads waiting)")
        print(f"{'build':<28} {'threads':>7} {'settle (s)':>11} {'measure (s)':>12} {'total (s)':>10} "
              f"{'first/this':>10} {'Mps/s':>7} {'steady Mps/s':>13} {'pair ns':>8} {'neigh ns':>9} "
              f"{'modify ns':>10} {'rebuilds':>8} {'steady Mps/cpu s':>16}")
        first = None
        for config in configs:
            settle = statistics.median(t[0] for t in times[n][config])
            measure = statistics.median(t[1] for t in times[n][config])
            pair, neigh, rebuilds, modify, cpu_rate = (statistics.median(t[2][k] for t in times[n][config])
                                                       for k in range(5))
            total = settle + measure
            first = first or total
            rate = n * (args.settle + args.measure) / total
            steady = n * args.measure / measure
            rates[config][n] = (rate, steady, cpu_rate)
            per = 1e9 / (n * args.measure)
            print(f"{str(config[0]):<28} {config[1]:>7} {settle:>11.2f} {measure:>12.2f} {total:>10.2f} "
                  f"{first / total:>10.2f} {rate / 1e6:>7.2f} {steady / 1e6:>13.2f} {pair * per:>8.1f} "
                  f"{neigh * per:>9.1f} {modify * per:>10.1f} {rebuilds:>8.0f} {cpu_rate / 1e6:>16.2f}")
    if len(args.sizes) > 1:
        print("\nrate at N / rate at the first N (goal at 1,000,000 against 10,000: >= 0.9)")
        print(f"{'build':<28} {'threads':>7} {'N':>9} {'total':>7} {'steady':>7} {'steady per cpu s':>16}")
        for config in configs:
            base = next(iter(rates[config].values()))
            for n, (rate, steady, cpu_rate) in list(rates[config].items())[1:]:
                print(f"{config[0]!s:<28} {config[1]:>7} {n:>9} {rate / base[0]:>7.2f} {steady / base[1]:>7.2f} "
                      f"{cpu_rate / base[2]:>16.2f}")


if __name__ == "__main__":
    main()
