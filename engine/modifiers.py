"""Modifiers (after LAMMPS' fixes): created by `create modifier`, active once fixed.

Each kind is a class in `MODIFIERS`; a new kind is a new class. A modifier either adds to the forces inside
the compiled step loop (gravity: its acceleration enters the kernel's force clearing) or acts at output steps,
every `every` steps (print, vtk, restart), outside compiled code.
"""
from __future__ import annotations

import numpy as np

from . import quantities
from .output import write_vtk
from .script import Fields
from .writers import CsvSeries


class Modifier:
    """Base: a named modifier of one kind. `every` is None for modifiers that act inside the step loop."""

    kind = ""
    every: int | None = None

    def __init__(self, name: str, fields: Fields):
        self.name = name

    def acceleration(self):
        """Body acceleration (m/s^2, 3) this modifier adds to every particle, or None."""
        return None

    def quantities(self) -> list:
        """Quantities this modifier evaluates (checked before a run)."""
        return []

    def output(self, sim, start: bool):
        """Act at a step that is a multiple of `every` (start: the first row of a run)."""

    def close(self):
        """Release open files."""


class Gravity(Modifier):
    """Constant body acceleration: F = m g (fix gravity)."""

    kind = "gravity"

    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.vector = fields.vector("acceleration", default=[0.0, 0.0, -9.81])

    def acceleration(self):
        return self.vector


class _Periodic(Modifier):
    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.every = fields.integer("every", required=True, minimum=1)


class Print(_Periodic):
    """`step,time` + chosen quantities every N steps into a CSV file."""

    kind = "print"

    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.file = fields.string("file", required=True)
        self.names = fields.strings("quantities", required=True)
        for q in self.names:
            if not quantities.known(q):
                raise fields.error("quantities", f"names unknown quantity '{q}' (known: "
                                   f"{', '.join(quantities.GLOBAL_QUANTITIES)}, or e.g. z[1] for particle 1)")
        self.series: CsvSeries | None = None

    def quantities(self) -> list:
        return self.names

    def output(self, sim, start: bool):
        columns = ["step", "time"] + self.names
        if self.series is None:
            self.series = CsvSeries(self.file, columns, "print file")
        self.series.write(sim.step, sim.output.row(sim, columns))

    def close(self):
        if self.series is not None:
            self.series.close()


class VtkDump(_Periodic):
    """Particles as VTK PolyData, post/<prefix>_<step>.vtp."""

    kind = "vtk"

    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.folder = fields.string("folder", "post")
        self.prefix = fields.string("prefix", "particles")

    def output(self, sim, start: bool):
        write_vtk(sim, self.folder, self.prefix)


class RestartWriter(_Periodic):
    """A restart file every N steps (not at a run's first row); {step} in the name is the step."""

    kind = "restart"

    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.file = fields.string("file", "restart_{step}.npz")

    def output(self, sim, start: bool):
        if not start:
            from .restart import write_restart

            write_restart(sim, self.file.replace("{step}", str(sim.step)))


MODIFIERS = {cls.kind: cls for cls in (Gravity, Print, VtkDump, RestartWriter)}


def create(fields: Fields) -> Modifier:
    name = fields.string("name", required=True)
    kind = fields.string("kind", required=True, choices=tuple(MODIFIERS))
    return MODIFIERS[kind](name, fields)


def gravity_vector(active) -> np.ndarray:
    """Sum of the active modifiers' accelerations (m/s^2)."""
    g = np.zeros(3)
    for mod in active:
        a = mod.acceleration()
        if a is not None:
            g += a
    return g
