#!/usr/bin/env python3
"""Contact time (s) and restitution of the head-on impact, from the run's thermo, into impact.txt.

Runs in the run folder of any of the four codes and reads the thermo through the harness adapter of the
code that wrote it. Without gravity the kinetic energy is constant in free flight; the contact lasts from
the first row whose ke differs from the initial one by more than 1e-7 (relative) to the first later row
from which ke stays constant, so the measured time is exact to about one time step (thermo every step).
Restitution: both spheres have the same mass and opposite velocities, so e = |v'| / |v| = sqrt(ke_end / ke_0).
"""
import math
from pathlib import Path

from harness.adapters import get_adapter

here = Path(".")
code = ("lammps" if (here / "log.lammps").is_file() else "liggghts" if (here / "log.liggghts").is_file()
        else "yade" if (here / "log.yade").is_file() else "dem")
thermo = get_adapter(code).read_thermo(here)
time = thermo["time"] if "time" in thermo else thermo["step"] * 1e-5
ke = thermo["ke"].to_numpy()
rel = 1e-7
moving = [i for i in range(1, len(ke)) if abs(ke[i] - ke[0]) > rel * ke[0]]
start = moving[0]
end = next(i for i in range(start, len(ke) - 2) if abs(ke[i + 1] - ke[i]) <= rel * ke[0]
           and abs(ke[-1] - ke[i]) <= rel * ke[0])
contact_time = float(time.iloc[end] - time.iloc[start - 1])
with open("impact.txt", "w") as out:
    out.write("contact_time restitution\n")
    out.write(f"{contact_time!r} {float(math.sqrt(ke[-1] / ke[0]))!r}\n")
