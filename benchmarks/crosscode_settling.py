"""Speed of the four DEM codes on one settling scene, side by side through the harness (issue 13).

The scene: N = n^3 spheres (r = 1.5 mm, rho = 2500 kg/m^3) on a simple cubic lattice of spacing 3.5 mm, all
moving at (0.3, 0.1, 0) m/s, fall into a box of five plane walls (n x 3.5 mm wide) under gravity and settle.
The contact model is the one all four codes compute alike (docs/crosscode.md): Hertz with LIGGGHTS' normal
damping for e = 0.5, normal force clamped at 0, tangential history without damping, mu = 0.3,
Y = 5e6 Pa, nu = 0.45; dt = 1e-5 s, STEPS steps, thermo every 1000 steps. The same particles in every code
(a lattice, no random insertion), so the work is the same.

The script writes the scene for the bundled engine, LIGGGHTS, LAMMPS and YADE into one test case (run.config
names the script per adapter), defines a target per code (engine: ``dem`` recipe at HEAD of this checkout;
the others: Debian's binaries) and runs them with ``harness run -j 1`` (one run at a time, so no two codes
share the cores). Figures, from the run records:

- loop s: the code's own stepping time (LIGGGHTS/LAMMPS ``Loop time``, the engine's timing.json ``total``
  without JIT compilation, YADE's ``O.run`` wall time from the yade_series helper);
- wall s: the whole program (start-up, the engine's compilation, YADE's plug-in loading);
- particle-steps/s = N x STEPS / loop s, and the loop time of each code over LIGGGHTS'.

    python benchmarks/crosscode_settling.py                          # n = 10, 20 (1000, 8000 spheres), 10000 steps
    python benchmarks/crosscode_settling.py --n 10 --steps 5000 --codes liggghts lammps
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SPACING = 0.0035
E, NU, MU = 5e6, 0.45, 0.3
BETA = math.log(0.5) / math.sqrt(math.log(0.5) ** 2 + math.pi ** 2)

IN_LIGGGHTS = """\
# Settling lattice (benchmarks/crosscode_settling.py), LIGGGHTS side
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
units           si
variable        lo equal -${HALF}
region          domain block ${lo} ${HALF} ${lo} ${HALF} 0.0 ${TOP} units box
create_box      1 domain
neighbor        0.001 bin
neigh_modify    delay 0
fix m1 all property/global youngsModulus peratomtype 5.e6
fix m2 all property/global poissonsRatio peratomtype 0.45
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.5
fix m4 all property/global coefficientFriction peratomtypepair 1 0.3
pair_style      gran model hertz tangential history limitForce on tangential_damping off
pair_coeff      * *
timestep        1e-5
fix gravity all gravity 9.81 vector 0.0 0.0 -1.0
fix floor all wall/gran model hertz tangential history primitive type 1 zplane 0.0 limitForce on tangential_damping off
fix xlo   all wall/gran model hertz tangential history primitive type 1 xplane ${lo} limitForce on tangential_damping off
fix xhi   all wall/gran model hertz tangential history primitive type 1 xplane ${HALF} limitForce on tangential_damping off
fix ylo   all wall/gran model hertz tangential history primitive type 1 yplane ${lo} limitForce on tangential_damping off
fix yhi   all wall/gran model hertz tangential history primitive type 1 yplane ${HALF} limitForce on tangential_damping off
lattice         sc ${SPACING} origin 0.5 0.5 0.5
variable        fill_lo equal -${HALF}+0.0001
variable        fill_hi equal ${HALF}-0.0001
region          fill block ${fill_lo} ${fill_hi} ${fill_lo} ${fill_hi} 0.0003 ${FILL_TOP} units box
create_atoms    1 region fill
set             group all density 2500 diameter 0.003
velocity        all set 0.3 0.1 0.0 units box
fix             integrate all nve/sphere
compute         rke all erotate/sphere
thermo_style    custom step atoms ke c_rke
thermo          1000
thermo_modify   norm no
run             ${STEPS}
"""

IN_LAMMPS = """\
# Settling lattice (benchmarks/crosscode_settling.py), LAMMPS side (walls: docs/crosscode.md)
variable        wall string "granular hertz/material 3448275.862 0.366651 0.45 tangential mindlin 4449388.209 0.0 0.3 damping tsuji limit_damping"
atom_style      sphere
atom_modify     map array
boundary        f f f
newton          off
comm_modify     vel yes
units           si
variable        lo equal -${HALF}
region          domain block ${lo} ${HALF} ${lo} ${HALF} 0.0 ${TOP} units box
create_box      1 domain
neighbor        0.001 bin
neigh_modify    delay 0
pair_style      granular
pair_coeff      * * hertz/material 5e6 0.366651 0.45 tangential mindlin NULL 0.0 0.3 damping tsuji limit_damping
timestep        1e-5
fix gravity all gravity 9.81 vector 0.0 0.0 -1.0
fix floor all wall/gran ${wall} zplane 0.0 NULL
fix xwalls all wall/gran ${wall} xplane ${lo} ${HALF}
fix ywalls all wall/gran ${wall} yplane ${lo} ${HALF}
lattice         sc ${SPACING} origin 0.5 0.5 0.5
variable        fill_lo equal -${HALF}+0.0001
variable        fill_hi equal ${HALF}-0.0001
region          fill block ${fill_lo} ${fill_hi} ${fill_lo} ${fill_hi} 0.0003 ${FILL_TOP} units box
create_atoms    1 region fill
set             group all diameter 0.003
set             group all density 2500
velocity        all set 0.3 0.1 0.0 units box
fix             integrate all nve/sphere
compute         rke all erotate/sphere
thermo_style    custom step atoms ke c_rke
thermo          1000
thermo_modify   norm no
run             ${STEPS}
"""

SCENE_PY = """\
# Settling lattice (benchmarks/crosscode_settling.py), YADE side (walls: 1 km spheres, docs/crosscode.md)
import math
import yade_series as series

v = series.variables(N_SIDE=10, SPACING=0.0035, HALF=0.0175, STEPS=10000)
beta = math.log(0.5) / math.sqrt(math.log(0.5) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
big, half = 1000.0, v["HALF"]
for center in ((0, 0, -big), (-half - big, 0, 0), (half + big, 0, 0), (0, -half - big, 0), (0, half + big, 0)):
    O.bodies.append(sphere(center, big, material=material, fixed=True))
n, s = v["N_SIDE"], v["SPACING"]
for i in range(n):
    for j in range(n):
        for k in range(n):
            body = O.bodies[O.bodies.append(sphere((-half + (i + 0.5) * s, -half + (j + 0.5) * s, (k + 0.5) * s),
                                                   0.0015, material=material))]
            body.state.vel = (0.3, 0.1, 0.0)
thermo = series.Thermo(every=1000)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=math.sqrt(5.0 / 6.0) * abs(beta), betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["STEPS"], thermo, timing=False)
"""


def engine_scene() -> list[dict]:
    """The scene for the bundled engine, with ${...} variables like the other scripts."""
    walls = [("floor", "z", 0.0), ("xlo", "x", "-${HALF}"), ("xhi", "x", "${HALF}"), ("ylo", "y", "-${HALF}"),
             ("yhi", "y", "${HALF}")]
    return [
        {"command": "create", "object": "domain", "lo": ["-${HALF}", "-${HALF}", 0.0], "hi": ["${HALF}", "${HALF}", "${TOP}"]},
        {"command": "create", "object": "material", "type": 1, "youngs_modulus": E, "poisson_ratio": NU, "density": 2500},
        {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": MU},
        {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history",
         "limit_force": True, "tangential_damping": False},
        *[{"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis, "position": position,
           "type": 1} for name, axis, position in walls],
        {"command": "create", "object": "lattice", "type": 1, "radius": 0.0015, "spacing": "${SPACING}",
         "region": {"shape": "box", "lo": ["-${HALF}", "-${HALF}", 0.0], "hi": ["${HALF}", "${HALF}", "${FILL_TOP}"]},
         "velocity": [0.3, 0.1, 0.0]},
        {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity", "acceleration": [0, 0, -9.81]},
        {"command": "fix", "name": "gravity"},
        {"command": "set", "property": "timestep", "value": 1e-5},
        {"command": "set", "property": "skin", "value": 0.001},
        {"command": "set", "property": "thermo", "every": 1000},
        {"command": "run", "steps": "${STEPS}"},
    ]


CODES = {
    "dem": {"repository": str(REPO), "revision": "HEAD", "recipe": "dem", "source_folder": "engine", "engine": "dem"},
    "liggghts": {"recipe": "system", "executable": "/usr/bin/liggghts", "engine": "liggghts"},
    "lammps": {"recipe": "system", "executable": "/usr/bin/lmp", "engine": "lammps"},
    "yade": {"recipe": "system", "executable": "/usr/bin/yade", "engine": "yade"},
}
SCRIPTS = {"dem": "scene.json", "liggghts": "in.liggghts", "lammps": "in.lammps", "yade": "scene.py"}


def write_testcase(folder: Path, sides: list[int], steps: int) -> None:
    folder.mkdir(parents=True)
    (folder / "scene.json").write_text(json.dumps(engine_scene(), indent=1))
    (folder / "in.liggghts").write_text(IN_LIGGGHTS)
    (folder / "in.lammps").write_text(IN_LAMMPS)
    (folder / "scene.py").write_text(SCENE_PY)
    runs = []
    for n in sides:
        half = round(n * SPACING / 2, 9)
        runs.append({"name": f"N{n ** 3}", "type": "serial", "timeout": 7200, "script": SCRIPTS,
                     "stability": False,
                     "variables": {"N_SIDE": n, "SPACING": SPACING, "HALF": half, "TOP": round(n * SPACING + 0.01, 9),
                                   "FILL_TOP": round(n * SPACING, 9), "STEPS": steps}})
    (folder / "run.config").write_text(json.dumps({"runs": runs}, indent=1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, nargs="+", default=[10, 20], help="spheres per lattice edge (N = n^3)")
    parser.add_argument("--steps", type=int, default=10000)
    parser.add_argument("--codes", nargs="+", default=list(CODES), choices=list(CODES))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="crosscode-bench-") as tmp:
        tmp = Path(tmp)
        write_testcase(tmp / "testcases" / "settling", args.n, args.steps)
        (tmp / "targets").mkdir()
        for code in args.codes:
            (tmp / "targets" / f"bench-{code}.json").write_text(
                json.dumps({**CODES[code], "testcases": [str(tmp / "testcases")]}))
        harness = [sys.executable, "-m", "harness.cli", "--machine", "bench", "--home", str(tmp / "home"),
                   "--targets", str(tmp / "targets")]
        result = subprocess.run(harness + ["run", "-j", "1", *[f"bench-{c}" for c in args.codes]], cwd=REPO,
                                capture_output=True, text=True)
        records = {}
        for path in (tmp / "home" / "runs").rglob("run.json"):
            record = json.loads(path.read_text())
            records[(record["adapter"], record["run"])] = record
        print(f"settling lattice, {args.steps} steps, dt = 1e-5 s; serial runs one at a time through "
              f"'harness run -j 1'")
        print(f"{'N':>6} {'code':>9} {'atoms':>6} {'loop s':>8} {'wall s':>8} {'p-steps/s':>10} {'loop / LIGGGHTS':>15}")
        for n in args.n:
            name = f"N{n ** 3}"
            reference = records.get(("liggghts", name))
            for code in args.codes:
                record = records.get((code, name))
                if record is None or record["state"] not in ("post_processed", "executed"):
                    reason = record["failure_message"][:80] if record else "no run record"
                    print(f"{n ** 3:>6} {code:>9} failed: {reason}")
                    continue
                atoms = record["series"][0]["columns"]["atoms"][-1]
                loop = record["timing"]["total"]
                ratio = (f"{loop / reference['timing']['total']:.2f}"
                         if reference and reference["timing"]["total"] else "-")
                print(f"{n ** 3:>6} {code:>9} {atoms:>6} {loop:>8.2f} {record['wall_time']:>8.2f} "
                      f"{atoms * args.steps / loop:>10.3e} {ratio:>15}", flush=True)
        if result.returncode not in (0, 1):
            raise SystemExit(f"harness run failed:\n{result.stdout}\n{result.stderr}")


if __name__ == "__main__":
    main()
