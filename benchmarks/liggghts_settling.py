"""Speed of LIGGGHTS on the settling scene, and the bundled engine's run time relative to it (issue 6).

The scene of the engine issue (engine/examples/settling.json): N spheres (r = 1.5 mm) packed at random into a
box of plane walls (half width 0.03 sqrt(N / 10000) m, packing height HEIGHT, default 0.2 m: at the example's
0.13 m, a solid fraction of 0.30, the engine's random packing places only ~95 % of the spheres) settle under gravity; Hertz +
tangential history, Y = 5e6 Pa, nu = 0.45, e = 0.5, mu = 0.3, rho = 2500 kg/m^3, dt = 1e-5 s; SETTLE steps,
then MEASURE steps on the bed. This script writes the same scene in LIGGGHTS syntax (random insertion with
fix insert/pack: the same statistics, not the same particles), puts both scripts in one test case whose
run.config names the script per adapter, and runs it through the harness (``harness run``) for a
``system`` target (/usr/bin/liggghts) and a ``dem`` target (engine/ of this checkout) on this machine in
this run. Figures, from the run records:

- particle-steps/s of each code over the whole run (loop time: LIGGGHTS' ``Loop time`` blocks summed, the
  engine's timing.json ``total``; neither includes start-up or the engine's JIT compilation),
- particle-steps/s of the MEASURE phase alone (the last loop block of each log),
- the run time ratio engine / LIGGGHTS (loop times, and wall times of the whole program).

    python benchmarks/liggghts_settling.py                      # N = 1000 and 10000, 30000 + 2000 steps
    python benchmarks/liggghts_settling.py --sizes 1000 --settle 10000 --measure 1000
    python benchmarks/liggghts_settling.py --liggghts-only      # LIGGGHTS' particle-steps/s only
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ENGINE_SCENE = REPO / "engine" / "examples" / "settling.json"
LIGGGHTS = shutil.which("liggghts") or "/usr/bin/liggghts"
sys.path.insert(0, str(REPO))  # the harness' adapters read the logs
from harness.adapters import get_adapter  # noqa: E402

# The settling scene in LIGGGHTS syntax, with the variable names of engine/examples/settling.json.
IN_SETTLING = """\
# Settling bed (benchmarks/liggghts_settling.py): the scene of engine/examples/settling.json for LIGGGHTS.
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
units           si

variable        lo equal -${HALF_WIDTH}
region          domain block ${lo} ${HALF_WIDTH} ${lo} ${HALF_WIDTH} -0.01 0.3 units box
create_box      1 domain
neighbor        0.001 bin
neigh_modify    delay 0

fix m1 all property/global youngsModulus peratomtype 5.e6
fix m2 all property/global poissonsRatio peratomtype 0.45
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.5
fix m4 all property/global coefficientFriction peratomtypepair 1 0.3

pair_style      gran model hertz tangential history
pair_coeff      * *
timestep        1e-5

fix gravity all gravity 9.81 vector 0.0 0.0 -1.0
fix floor  all wall/gran model hertz tangential history primitive type 1 zplane 0.0
fix left   all wall/gran model hertz tangential history primitive type 1 xplane ${lo}
fix right  all wall/gran model hertz tangential history primitive type 1 xplane ${HALF_WIDTH}
fix front  all wall/gran model hertz tangential history primitive type 1 yplane ${lo}
fix back   all wall/gran model hertz tangential history primitive type 1 yplane ${HALF_WIDTH}

# random packing of N spheres in the box up to HEIGHT, all inside, no overlaps (inserted at the first step)
region          packing block ${lo} ${HALF_WIDTH} ${lo} ${HALF_WIDTH} 0.0 ${HEIGHT} units box
fix             pts all particletemplate/sphere 15485863 atom_type 1 density constant 2500 radius constant 0.0015
fix             pdd all particledistribution/discrete 32452843 1 pts 1.0
fix             ins all insert/pack seed 49979687 distributiontemplate pdd insert_every once &
                overlapcheck yes all_in yes particles_in_region ${N} region packing ntry_mc 100000

fix             integrate all nve/sphere
compute         rke all erotate/sphere
thermo_style    custom step atoms ke c_rke
thermo          1000
thermo_modify   lost ignore norm no

run             ${SETTLE_STEPS}
unfix           ins
run             ${MEASURE_STEPS}
"""



def write_testcase(folder: Path, sizes: list[int], settle: int, measure: int, height: float) -> None:
    folder.mkdir(parents=True)
    shutil.copy(ENGINE_SCENE, folder / "scene.json")
    (folder / "in.settling").write_text(IN_SETTLING)
    runs = []
    for n in sizes:
        runs.append({"name": f"N{n}", "type": "serial", "timeout": 7200,
                     "script": {"dem": "scene.json", "liggghts": "in.settling"},
                     "variables": {"N": n, "SEED": 1, "HALF_WIDTH": round(0.03 * math.sqrt(n / 10000), 6),
                                   "HEIGHT": height, "DUMP_EVERY": 10 ** 9, "SETTLE_STEPS": settle,
                                   "MEASURE_STEPS": measure}})
    (folder / "run.config").write_text(json.dumps({"runs": runs}, indent=1))


def write_targets(folder: Path, testcases: Path, liggghts_only: bool) -> list[str]:
    folder.mkdir(parents=True)
    targets = {"bench-liggghts": {"recipe": "system", "executable": LIGGGHTS, "engine": "liggghts",
                                  "testcases": [str(testcases)]}}
    if not liggghts_only:
        targets["bench-dem"] = {"repository": str(REPO), "revision": "HEAD", "recipe": "dem",
                                "source_folder": "engine", "engine": "dem", "testcases": [str(testcases)]}
    for name, definition in targets.items():
        (folder / f"{name}.json").write_text(json.dumps(definition, indent=1))
    return list(targets)


def run_record(home: Path, target: str, run: str) -> dict:
    path = next((home / "runs").glob(f"*/{target}/**/{run}/run.json"))
    record = json.loads(path.read_text())
    if record["state"] not in ("post_processed", "executed"):
        raise SystemExit(f"{target} {run}: {record['state']}: {record['failure_message']}")
    return record


def loops(record: dict) -> list[tuple[float, int, int]]:
    """(loop time s, steps, particles) of each run block of a run's log."""
    blocks = get_adapter(record["adapter"]).loop_blocks(Path(record["folder"]))
    return [(block.seconds, block.steps, block.particles) for block in blocks]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--settle", type=int, default=30000, help="steps until the bed has formed")
    parser.add_argument("--measure", type=int, default=2000, help="steps timed on the settled bed")
    parser.add_argument("--height", type=float, default=0.2, help="height of the packing region, m")
    parser.add_argument("--liggghts-only", action="store_true", help="do not run the bundled engine")
    args = parser.parse_args()
    if not Path(LIGGGHTS).exists():
        raise SystemExit(f"{LIGGGHTS}: LIGGGHTS not installed (apt-get install liggghts)")

    with tempfile.TemporaryDirectory(prefix="liggghts-bench-") as tmp:
        tmp = Path(tmp)
        write_testcase(tmp / "testcases" / "settling", args.sizes, args.settle, args.measure, args.height)
        names = write_targets(tmp / "targets", tmp / "testcases", args.liggghts_only)
        harness = [sys.executable, "-m", "harness.cli", "--machine", "bench", "--home", str(tmp / "home"),
                   "--targets", str(tmp / "targets")]
        # one run at a time, so the two codes never share the cores
        result = subprocess.run(harness + ["run", "-j", "1", *names], cwd=REPO, capture_output=True, text=True)
        if result.returncode != 0:
            raise SystemExit(f"harness run failed:\n{result.stdout}\n{result.stderr}")

        print(f"settling scene, {args.settle} + {args.measure} steps, dt = 1e-5 s; loop times, serial runs")
        header = (f"{'N':>6} {'code':>9} {'particles':>9} {'loop s':>8} {'wall s':>8} {'p-steps/s':>10} "
                  f"{'measure p-steps/s':>17}")
        print(header)
        for n in args.sizes:
            rows = {}
            for target in names:
                record = run_record(tmp / "home", target, f"N{n}")
                blocks = loops(record)
                loop_time = sum(t for t, _, _ in blocks)
                particle_steps = sum(s * p for _, s, p in blocks)
                t_last, s_last, p_last = blocks[-1]
                rows[record["adapter"]] = (loop_time, record["wall_time"])
                print(f"{n:>6} {record['adapter']:>9} {p_last:>9} {loop_time:>8.2f} {record['wall_time']:>8.2f} "
                      f"{particle_steps / loop_time:>10.3e} {s_last * p_last / t_last:>17.3e}", flush=True)
            if "dem" in rows:
                (dem_loop, dem_wall), (lig_loop, lig_wall) = rows["dem"], rows["liggghts"]
                print(f"{n:>6} engine / LIGGGHTS run time: {dem_loop / lig_loop:.2f} (loop), "
                      f"{dem_wall / lig_wall:.2f} (wall)", flush=True)


if __name__ == "__main__":
    main()
