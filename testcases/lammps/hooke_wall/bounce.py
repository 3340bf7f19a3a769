#!/usr/bin/env python3
"""Contact time (s) and restitution of a single sphere bouncing off a wall without gravity, into bounce.txt.

Reads the thermo of the run's LAMMPS log (harness adapter); ke is constant in free flight, the contact lasts
from the first row where ke leaves its initial value (relative 1e-7) to the first row from which it stays
constant; restitution e = sqrt(ke_end / ke_0) (one sphere, a wall at rest).
"""
import math

from harness.adapters import get_adapter

thermo = get_adapter("lammps").read_thermo(".")
ke, step = thermo["ke"].to_numpy(), thermo["step"].to_numpy()
rel = 1e-7
start = next(i for i in range(1, len(ke)) if abs(ke[i] - ke[0]) > rel * ke[0])
end = next(i for i in range(start, len(ke) - 1) if abs(ke[i + 1] - ke[i]) <= rel * ke[0] and abs(ke[-1] - ke[i]) <= rel * ke[0])
with open("bounce.txt", "w") as out:
    out.write("contact_time restitution\n")
    out.write(f"{float(step[end] - step[start - 1]) * 1e-5!r} {float(math.sqrt(ke[-1] / ke[0]))!r}\n")
