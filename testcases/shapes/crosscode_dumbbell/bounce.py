#!/usr/bin/env python3
"""The dumbbell's translational and rotational energy (J) from step 500 on, in either code: post/bounce.csv.

LIGGGHTS inserts the body at step 1 (its step-0 row has no particle), so the rows every code has are those
from the first thermo step on. Energies: the engine's thermo ke and rke are its bodies' (engine/clumps.py);
LIGGGHTS' are compute ke/multisphere (column kems: the adapter drops the c_) and erotate/multisphere (rke);
YADE's those of its bodies, each clump once (harness/adapters/yade_support/yade_series.py).
"""
import csv
from pathlib import Path

from harness.adapters import adapter_of_run

adapter = adapter_of_run(".")
thermo = adapter.read_thermo(".")
ke = thermo["kems"] if adapter.name == "liggghts" else thermo["ke"]
rke = thermo["rke"]
Path("post").mkdir(exist_ok=True)
with open("post/bounce.csv", "w", newline="") as handle:
    out = csv.writer(handle)
    out.writerow(["step", "ke", "rke"])
    for step, k, r in zip(thermo["step"], ke, rke):
        if step >= 500:
            out.writerow([int(step), repr(float(k)), repr(float(r))])
