"""Helpers for the YADE tests: real runs of Debian's /usr/bin/yade (2023.02a) through the adapter's command."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from harness_process import PROJECT, harness, records, series  # noqa: F401  (the YADE tests import them from here)

from harness.adapters.yade import YadeAdapter

YADE = shutil.which("yade") or "/usr/bin/yade"
EXAMPLES = Path("/usr/share/doc/yade/examples")

needs_yade = pytest.mark.skipif(not Path(YADE).exists(), reason="YADE not installed (apt-get install yade)")


def run_yade(folder: Path, script: str, variables: dict | None = None, executable: list[str] | None = None,
             mpi: list[str] | None = None, timeout: float = 120, wait: bool = True):
    """Run a YADE script in ``folder`` with the adapter's command line (stdout/stderr into the folder)."""
    adapter = YadeAdapter()
    cmd = adapter.command(executable or [YADE], script, variables or {}, adapter.log_file(), mpi)
    out, err = open(folder / "stdout.txt", "w"), open(folder / "stderr.txt", "w")
    process = subprocess.Popen(cmd, cwd=folder, stdout=out, stderr=err, text=True)
    if not wait:
        return process
    process.wait(timeout=timeout)
    out.close()
    err.close()
    return process


#: one sphere's mass, kg: 4/3 pi r^3 rho with r = 1.5 mm, rho = 2500 kg/m^3
MASS = 4.0 / 3.0 * 3.141592653589793 * 0.0015 ** 3 * 2500

# Two spheres falling freely (no contact), a VTKRecorder, and a report of the process' own listening
# TCP sockets (from /proc: the socket inodes among its file descriptors that /proc/net/tcp lists as LISTEN).
FALL = """\
import math, os
import yade_series as series

v = series.variables(steps=1000, thermo_every=100, label="none")
O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
O.bodies.append([sphere((0, 0, 0.05), 0.0015), sphere((0.01, 0, 0.05), 0.0015)])
for b in O.bodies:
    b.state.vel = (0.3, 0.1, 0)
thermo = series.Thermo(every=v["thermo_every"])
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_MindlinPhys()],
                             [Law2_ScGeom_MindlinPhys_Mindlin()]),
             thermo.engine(), NewtonIntegrator(damping=0, gravity=(0, 0, -9.81)),
             VTKRecorder(fileName="post/fall-", recorders=["spheres", "velocity", "mass"], iterPeriod=500)]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
inodes = set()
for fd in os.listdir("/proc/self/fd"):
    try:
        link = os.readlink("/proc/self/fd/" + fd)
    except OSError:
        continue
    if link.startswith("socket:["):
        inodes.add(link[8:-1])
listening = 0
for table in ("/proc/net/tcp", "/proc/net/tcp6"):
    try:
        rows = open(table).read().splitlines()[1:]
    except OSError:
        continue
    for row in rows:
        words = row.split()
        if words[3] == "0A" and words[9] in inodes:
            listening += 1
print("label", v["label"], "listening sockets", listening)
"""
