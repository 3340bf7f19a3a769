"""Helpers for the LAMMPS tests: real runs of Debian's /usr/bin/lmp (29 Sep 2021, GRANULAR) on small scenes."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.adapters.lammps import LammpsAdapter

PROJECT = Path(__file__).resolve().parents[2]
LMP = shutil.which("lmp") or "/usr/bin/lmp"
EXAMPLES = Path("/usr/share/lammps/examples")

needs_lammps = pytest.mark.skipif(not Path(LMP).exists(), reason="LAMMPS not installed (apt-get install lammps)")
needs_mpirun = pytest.mark.skipif(shutil.which("mpirun") is None,
                                  reason="mpirun not installed (apt-get install openmpi-bin)")


def run_lammps(folder: Path, script: str, variables: dict | None = None, nprocs: int = 1,
               timeout: float = 120) -> subprocess.CompletedProcess:
    """Run LAMMPS in ``folder`` with the adapter's command line; stdout/stderr land in the folder."""
    adapter = LammpsAdapter()
    from harness.runner import mpi_prefix
    from harness.targets import parse_target

    mpi = None
    if nprocs > 1:
        target = parse_target("t", {"recipe": "system", "executable": LMP, "engine": "lammps"}, folder / "t.json")
        mpi = mpi_prefix(target, {"type": "mpi", "nprocs": nprocs})
    cmd = adapter.command([LMP], script, variables or {}, adapter.log_file(), mpi)
    (folder / "post").mkdir(exist_ok=True)
    result = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, errors="replace", timeout=timeout)
    (folder / "stdout.txt").write_text(result.stdout)
    (folder / "stderr.txt").write_text(result.stderr)
    return result


def harness(home: Path, *args: str, targets: Path | None = None, check: bool = True):
    cmd = [sys.executable, "-m", "harness.cli", "--machine", "testbox", "--home", str(home)]
    if targets is not None:
        cmd += ["--targets", str(targets)]
    result = subprocess.run(cmd + list(args), cwd=PROJECT, capture_output=True, text=True, errors="replace",
                            timeout=600)
    if check:
        assert result.returncode == 0, result.stdout + result.stderr
    return result


def records(home: Path, target: str) -> dict[str, dict]:
    """run.json records of a target's runs by 'test case/run' (the newest per name)."""
    found = {}
    for path in sorted((home / "runs" / "testbox" / target).rglob("run.json"), key=lambda p: p.stat().st_mtime):
        record = json.loads(path.read_text())
        found[f"{record['testcase']}/{record['run']}"] = record
    return found


def series(record: dict, kind: str) -> dict:
    return next(s for s in record["series"] if s["kind"] == kind)["columns"]


# Free fall of 36 spheres in two run blocks: the second changes thermo_style (adds CPU), a lattice
# 4 mm apart (r = 1.5 mm, no contacts), a custom dump every 250 steps, a deliberate WARNING (new thermo_style).
FREE_FALL = """\
units           si
atom_style      sphere
atom_modify     map array
boundary        f f f
newton          off
comm_modify     vel yes
region          domain block -0.02 0.02 -0.02 0.02 0.0 0.06 units box
create_box      1 domain
neighbor        0.001 bin
neigh_modify    delay 0
pair_style      granular
pair_coeff      * * hertz/material 5e6 0.5 0.45 tangential mindlin NULL 1.0 0.3 damping tsuji
timestep        1e-5
fix             gravity all gravity 9.81 vector 0.0 0.0 -1.0
lattice         sc 0.004 origin 0.5 0.5 0.5
region          fill block -0.011 0.011 -0.011 0.011 0.04 0.044 units box
create_atoms    1 region fill
set             group all diameter 0.003
set             group all density 2500
velocity        all set 0.3 0.1 0.0 units box
fix             integrate all nve/sphere
compute         spin all erotate/sphere
thermo_style    custom step atoms ke c_spin
thermo          100
thermo_modify   norm no
dump            particles all custom 250 post/fall_*.dump id type x y z vx vy vz radius mass omegax omegay omegaz
run             500
thermo_style    custom step atoms ke c_spin cpu
thermo_modify   norm no
run             500
"""
N_FREE_FALL = 6 * 6  # lattice points (i + 1/2) 4 mm inside the fill region: one layer at z = 42 mm
#: one sphere's mass, kg: 4/3 pi r^3 rho
MASS = 4.0 / 3.0 * 3.141592653589793 * 0.0015 ** 3 * 2500
