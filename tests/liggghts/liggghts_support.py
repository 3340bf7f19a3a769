"""Helpers for the LIGGGHTS tests: real runs of /usr/bin/liggghts (Debian package ``liggghts``) on small scenes.

Tests that need the binary skip with the reason when it is absent; CI installs it (``.ci/run``).
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from harness_process import PROJECT, harness, records, run_code, series  # noqa: F401  (the LIGGGHTS tests import them from here)

from harness.adapters.liggghts import LiggghtsAdapter

SCENES = PROJECT / "testcases" / "liggghts"
LIGGGHTS = shutil.which("liggghts") or "/usr/bin/liggghts"

needs_liggghts = pytest.mark.skipif(not Path(LIGGGHTS).exists(),
                                    reason="LIGGGHTS not installed (apt-get install liggghts)")
needs_mpirun = pytest.mark.skipif(shutil.which("mpirun") is None,
                                  reason="mpirun not installed (apt-get install openmpi-bin)")


def run_liggghts(folder: Path, script: str, variables: dict | None = None, nprocs: int = 1,
                 timeout: float = 120) -> subprocess.CompletedProcess:
    """Run LIGGGHTS in ``folder`` through the adapter's command line; stdout/stderr land in the folder."""
    return run_code(LiggghtsAdapter(), [LIGGGHTS], folder, script, variables, nprocs, timeout)


def copy_scene(name: str, destination: Path) -> Path:
    folder = destination / name
    shutil.copytree(SCENES / name, folder)
    return folder


# A free fall of a lattice of spheres in two run blocks with a thermo_style change between them, a
# time-step check that prints WARNING lines inside the thermo table, and a VTK dump.
FREE_FALL = """\
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
units           si
region          domain block -0.02 0.02 -0.02 0.02 0.0 0.06 units box
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
fix floor   all wall/gran model hertz tangential history primitive type 1 zplane 0.0
# 6 x 6 x 3 spheres 4 mm apart (radius 1.5 mm: no contacts), 40 mm above the floor
lattice         sc 0.004 origin 0.5 0.5 0.5
region          fill block -0.011 0.011 -0.011 0.011 0.04 0.052 units box
create_atoms    1 region fill
set             group all density 2500 diameter 0.003
fix             integrate all nve/sphere
fix             check all check/timestep/gran 100 0.01 0.01
compute         spin all erotate/sphere
thermo_style    custom step atoms ke c_spin
thermo          100
variable        prefix string post/fall
dump            particles all custom/vtk 250 ${prefix}_*.vtk id type x y z vx vy vz radius omegax omegay omegaz
run             500
thermo_style    custom step atoms ke c_spin cpu
run             500
"""
N_FREE_FALL = 6 * 6 * 3
