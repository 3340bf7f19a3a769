#!/usr/bin/env python3
"""Energies (J) and centre-of-mass height (m) of the settling pile from step 1000 on, in either code:
post/pile.csv (step, ke, rke, com_z).

LIGGGHTS inserts the bodies at step 1 (its step-0 row has none), so the rows every code has start at the
first thermo step. The engine's ke, rke and com_z are its bodies' (engine/clumps.py); LIGGGHTS' are
compute ke/multisphere (column kems), erotate/multisphere (rke) and xcm(all,z) of the member spheres (for
spheres that do not overlap, the bodies' centre of mass); YADE's those of its bodies, each clump once
(scene.py, harness/adapters/yade_support/yade_series.py).
"""
import csv
from pathlib import Path

from harness.adapters import adapter_of_run

adapter = adapter_of_run(".")
thermo = adapter.read_thermo(".")
ke = thermo["kems"] if adapter.name == "liggghts" else thermo["ke"]
Path("post").mkdir(exist_ok=True)
with open("post/pile.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["step", "ke", "rke", "com_z"])
    for step, k, r, z in zip(thermo["step"], ke, thermo["rke"], thermo["com_z"]):
        if step >= 1000:
            out.writerow([int(step), repr(float(k)), repr(float(r)), repr(float(z))])
