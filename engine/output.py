"""Output at the steps Python looks at the state: thermo rows, the active modifiers' files, VTK dumps.

Rows are written at a run's start, every N steps and at its end (like LIGGGHTS' thermo). A global quantity
that is not finite stops the run instead of reaching a file.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from . import quantities, superquadrics
from .errors import RunFailure, output_failure
from .writers import CsvSeries, write_vtp

THERMO_FIRST = ["step", "time", "atoms", "ke", "rke"]


class Output:
    """Thermo settings and series; the run being written (where, end step) for messages and the last row."""

    def __init__(self):
        self.thermo_every = 0
        self.thermo_columns = list(THERMO_FIRST)
        self.thermo_file = "thermo.csv"
        self.thermo: CsvSeries | None = None
        self.where = ""
        self.end_step = None

    def set_thermo(self, every: int, columns: list, file: str):
        self.thermo_every = every
        self.thermo_columns = THERMO_FIRST + [c for c in columns if c not in THERMO_FIRST]
        self.close()
        self.thermo_file = file

    def every(self, active) -> list:
        """Intervals (steps) at which something is written."""
        return ([self.thermo_every] if self.thermo_every else []) + [m.every for m in active if m.every]

    def row(self, sim, columns) -> list:
        """Values of output columns; a value that is not finite stops the run before it reaches a file, naming
        the column and the step: a particle column whose particle is not present (removed by an outlet, lost,
        or not inserted yet), a centre of mass without particles, a global quantity gone inf or NaN."""
        values = [quantities.evaluate(sim, c) for c in columns]
        for c, value in zip(columns, values):
            if isinstance(value, float) and not math.isfinite(value):
                m = quantities.PARTICLE_QUANTITY.match(c)
                if m:
                    raise RunFailure(f"{self.where}: column '{c}': particle {m.group(2)} is not present at step "
                                     f"{sim.step} (removed by an outlet, left the domain, or not inserted yet)")
                if c.startswith("com_") and sim.n == 0:
                    raise RunFailure(f"{self.where}: column '{c}': no centre of mass without particles (step "
                                     f"{sim.step})")
                raise RunFailure(f"{self.where}: non-finite {c} ({value}) at step {sim.step}")
        return values

    def write(self, sim, start: bool):
        """Everything due at the current step (start: the first row of a run)."""
        t0 = time.perf_counter()
        if self.thermo is None:
            self.thermo = CsvSeries(self.thermo_file, self.thermo_columns, "thermo file")
        step = sim.step
        if start or (self.thermo_every and step % self.thermo_every == 0) or step == self.end_step:
            self.thermo.write(step, self.row(sim, self.thermo_columns))
        for mod in sim.active_modifiers():
            if mod.every and step % mod.every == 0:
                mod.output(sim, start)
        sim.timing["output"] += time.perf_counter() - t0

    def close(self):
        if self.thermo is not None:
            self.thermo.close()
            self.thermo = None


def write_vtk(sim, folder: str, prefix: str):
    """post/<prefix>_<step>.vtp with the particles ordered by id, whatever their memory order."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise output_failure("VTK dump folder", folder, exc) from None
    s = sim.state
    order = np.argsort(s.pid, kind="stable")
    write_vtp(folder / f"{prefix}_{sim.step}.vtp", s.pid[order], s.ptype[order] + 1, s.x[order], s.v[order],
              s.f[order], s.omega[order], s.radius[order],
              # clump members: the id of their body (engine/clumps.py), 0 for a free sphere
              extra={} if sim.bodies is None else {"body": sim.bodies.bid[np.maximum(
                  sim.bodies.member_body[s.pid[order]], 0)] * (sim.bodies.member_body[s.pid[order]] >= 0)})
    if sim.superquadrics is not None:  # a point per body, with its orientation and shape (engine/superquadrics.py)
        superquadrics.write_vtk(sim, folder, prefix)
