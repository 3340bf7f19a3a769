"""Helpers for the LAMMPS tests: real runs of Debian's /usr/bin/lmp (29 Sep 2021, GRANULAR) on small scenes."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from harness_process import PROJECT, harness, records, run_code, series  # noqa: F401  (the LAMMPS tests import them from here)

from harness.adapters.lammps import LammpsAdapter

LMP = shutil.which("lmp") or "/usr/bin/lmp"
EXAMPLES = Path("/usr/share/lammps/examples")

needs_lammps = pytest.mark.skipif(not Path(LMP).exists(), reason="LAMMPS not installed (apt-get install lammps)")
needs_mpirun = pytest.mark.skipif(shutil.which("mpirun") is None,
                                  reason="mpirun not installed (apt-get install openmpi-bin)")


def run_lammps(folder: Path, script: str, variables: dict | None = None, nprocs: int = 1,
               timeout: float = 120) -> subprocess.CompletedProcess:
    """Run LAMMPS in ``folder`` with the adapter's command line; stdout/stderr land in the folder."""
    return run_code(LammpsAdapter(), [LMP], folder, script, variables, nprocs, timeout)


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
