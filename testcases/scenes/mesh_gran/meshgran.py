#!/usr/bin/env python3
"""Statistics of the meshGran tutorial from the run's thermo, in either code (docs/scenes.md, mesh tutorial).

Runs in the run folder of the bundled engine or LIGGGHTS and reads the thermo the code wrote (the engine's
thermo.csv, the thermo table of log.liggghts); it needs only numpy, not the harness package (the harness runs
post scripts with the build's PYTHONPATH, where the harness need not be importable). The two codes insert different random packets (LIGGGHTS' insert/stream and the engine's
seeded insert modifier draw their own positions), so single particles are never compared; what the chute
does with the stream is: how much mass it holds, when the mass arrives on the floor, and that it all arrives.
Thermo columns (the codes name them differently): the total mass, the mass whose centres are in the floor
region (z <= -1.1 m, the whole floor) and in the chute region (x 0.19 ... 0.38 m, z >= -0.5 m: the inlet, the
bend, the ledge and the inclined part). Writes:

- meshgran.csv: per thermo row time (s), atoms, mass_all, mass_floor, mass_chute (kg), ke, rke (J), and the
  same masses and ke as means over the WINDOW s ending at the row (window_*): the cross-code series.
- meshgran_summary.txt: ``inserted_count inserted_mass floor_fraction t_floor_half t_floor_90 chute_peak t_chute_peak``
  compared word by word with rtol: the particles and mass inserted, the fraction of the inserted mass on the
  floor at the end, the times (s) at which the floor holds half and 90 % of it, the largest mass held in the
  chute (kg) and when.
- meshgran_end.csv: ``chute_count ke_end rke_end floor_count`` at the last row: particles left in the chute
  (on the ledge), the remaining kinetic energies (J). For expectations only: the few particles on the ledge
  and the last bounces differ from run to run (docs/scenes.md).
"""
import csv
from pathlib import Path

import numpy as np

TIMESTEP = 5e-5          # s, both scripts' dt (LIGGGHTS prints no time column)
RADIUS = 0.005           # m
DENSITY = 2500.0         # kg/m^3
WINDOW = 0.1             # s, the averaging window of the cross-code series (five insertion packets)
PARTICLE_MASS = DENSITY * 4.0 / 3.0 * np.pi * RADIUS ** 3

#: the thermo column of each quantity: engine name, LIGGGHTS variable (printed without its v_ prefix)
#: (LIGGGHTS 3.8 cuts thermo header names to 8 characters)
COLUMNS = {"mass_all": ("mass[type=1]", "m_all"), "mass_floor": ("mass[region=floor]", "m_floor"),
           "mass_chute": ("mass[region=chute]", "m_chute")}


def read_engine_thermo(path: Path) -> dict:
    """Columns of the engine's thermo.csv (a header naming the quantities, quoted when they hold a comma)."""
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return {name: np.array([float(row[i]) for row in rows[1:]]) for i, name in enumerate(rows[0])}


def read_liggghts_thermo(path: Path) -> dict:
    """Columns of the thermo table of a LIGGGHTS log: the rows of the header's width after ``Step ...`` (INFO
    lines of the insertion in between are skipped), up to ``Loop time``; one run, as in.liggghts has.
    LIGGGHTS prints ``KinEng`` for ke, a compute or variable without its ``c_``/``v_`` prefix."""
    header, rows = None, []
    for line in path.read_text(errors="replace").splitlines():
        words = line.split()
        if words[:1] == ["Step"]:
            header, rows = words, []
        elif header and line.startswith("Loop time"):
            break
        elif header and len(words) == len(header):
            try:
                rows.append([float(w) for w in words])
            except ValueError:
                pass
    if not header or not rows:
        raise SystemExit(f"{path}: no thermo table")
    names = {"Step": "step", "Atoms": "atoms", "KinEng": "ke"}
    return {names.get(name, name): np.array([row[i] for row in rows]) for i, name in enumerate(header)}


def column(table: dict, names):
    for name in names:
        if name in table:
            return table[name]
    raise SystemExit(f"no thermo column {' or '.join(names)} (columns: {', '.join(table)})")


def first_time(time, values, level):
    """First time (s) at which values reach level, linearly interpolated between rows; nan if never."""
    above = np.flatnonzero(values >= level)
    if above.size == 0:
        return float("nan")
    k = int(above[0])
    if k == 0:
        return float(time[0])
    t0, t1, v0, v1 = time[k - 1], time[k], values[k - 1], values[k]
    return float(t0 + (level - v0) * (t1 - t0) / (v1 - v0))


here = Path(".")
code = "liggghts" if (here / "log.liggghts").is_file() else "dem"
thermo = read_liggghts_thermo(here / "log.liggghts") if code == "liggghts" else read_engine_thermo(here / "thermo.csv")
time = thermo["step"] * TIMESTEP
atoms = thermo["atoms"]
ke = thermo["ke"]
rke = thermo["rke"]
mass = {key: column(thermo, names) for key, names in COLUMNS.items()}

rows_per_window = max(1, int(round(WINDOW / (time[1] - time[0])))) if len(time) > 1 else 1


def window_mean(values):
    """Mean over the rows of the last WINDOW s up to each row (fewer at the start)."""
    cumulative = np.concatenate([[0.0], np.cumsum(values)])
    k = np.arange(1, len(values) + 1)
    lo = np.maximum(0, k - rows_per_window)
    return (cumulative[k] - cumulative[lo]) / (k - lo)


with open("meshgran.csv", "w") as out:
    names = ["time", "atoms", "mass_all", "mass_floor", "mass_chute", "ke", "rke",
             "window_mass_floor", "window_mass_chute", "window_ke"]
    series = [time, atoms, mass["mass_all"], mass["mass_floor"], mass["mass_chute"], ke, rke,
              window_mean(mass["mass_floor"]), window_mean(mass["mass_chute"]), window_mean(ke)]
    out.write(",".join(names) + "\n")
    for row in zip(*series):
        out.write(",".join(repr(float(v)) for v in row) + "\n")

inserted_count = int(atoms[-1])
inserted_mass = float(mass["mass_all"][-1])
floor_fraction = float(mass["mass_floor"][-1] / inserted_mass)
t_half = first_time(time, mass["mass_floor"], 0.5 * inserted_mass)
t_90 = first_time(time, mass["mass_floor"], 0.9 * inserted_mass)
k_peak = int(np.argmax(mass["mass_chute"]))
with open("meshgran_summary.txt", "w") as out:
    out.write("inserted_count inserted_mass floor_fraction t_floor_half t_floor_90 chute_peak t_chute_peak\n")
    out.write(f"{inserted_count} {inserted_mass:.6g} {floor_fraction:.4f} {t_half:.4f} {t_90:.4f} "
              f"{mass['mass_chute'][k_peak]:.5g} {time[k_peak]:.3f}\n")
with open("meshgran_end.csv", "w") as out:
    out.write("chute_count,floor_count,ke_end,rke_end\n")
    out.write(f"{mass['mass_chute'][-1] / PARTICLE_MASS:.3f},{mass['mass_floor'][-1] / PARTICLE_MASS:.3f},"
              f"{float(ke[-1])!r},{float(rke[-1])!r}\n")
print(f"{code}: {inserted_count} particles, {inserted_mass:.6g} kg inserted; floor {floor_fraction:.4f} of it at "
      f"the end, half at {t_half:.3f} s, 90 % at {t_90:.3f} s; chute peak {mass['mass_chute'][k_peak]:.4g} kg at "
      f"{time[k_peak]:.2f} s, {mass['mass_chute'][-1] / PARTICLE_MASS:.0f} particles left in it; ke end {ke[-1]:.3g} J")
