"""Modifiers (after LAMMPS' fixes): created by `create modifier`, active once fixed.

Each kind is a class in `MODIFIERS`; a new kind is a new class. A modifier either adds to the forces inside
the compiled step loop (gravity: its acceleration enters the kernel's force clearing) or acts at output steps,
every `every` steps (print, vtk, restart), outside compiled code. Insert and outlet modifiers change the
particle set at their steps (`change_particles`, before the output of that step; engine/insertion.py).
"""
from __future__ import annotations

import numpy as np

from . import insertion, quantities
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

    def particle_types(self) -> list:
        """Material types of the particles this modifier brings in (checked for interactions before a run)."""
        return []

    def problem(self, sim) -> str | None:
        """Why a run cannot start with this modifier fixed, or None."""
        return None

    def act(self, sim) -> int:
        """Change the particle set at the current step if it is one of this modifier's (insert, outlet)."""
        return 0

    def state(self) -> dict:
        """Counters a restart file carries (JSON values); empty for modifiers without state."""
        return {}

    def restore(self, values: dict):
        """Counters from a restart file (`state`)."""


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
        self.file = fields.output_path("file", required=True)
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
        self.folder = fields.output_path("folder", "post")
        self.prefix = fields.output_path("prefix", "particles")

    def output(self, sim, start: bool):
        write_vtk(sim, self.folder, self.prefix)


class RestartWriter(_Periodic):
    """A restart file every N steps (not at a run's first row); {step} in the name is the step."""

    kind = "restart"

    def __init__(self, name: str, fields: Fields):
        super().__init__(name, fields)
        self.file = fields.output_path("file", "restart_{step}.npz")

    def output(self, sim, start: bool):
        if not start:
            from .restart import write_restart  # engine/restart.py imports this module

            write_restart(sim, self.file.replace("{step}", str(sim.step)))


class _ParticleSetChange(Modifier):
    """A modifier that inserts or removes particles at its steps: a wrapper of engine/insertion.py."""

    engine_class = None

    def __init__(self, name: str, fields: Fields, sim):
        super().__init__(name, fields)
        self.engine = self.engine_class(name, fields, sim)
        self.every = self.engine.every

    def problem(self, sim):
        return self.engine.problem(sim)

    def act(self, sim) -> int:
        return self.engine.act(sim)

    def state(self) -> dict:
        return {key: getattr(self.engine, key) for key in self.engine.STATE}

    def restore(self, values: dict):
        for key in self.engine.STATE:
            if key in values:
                setattr(self.engine, key, type(getattr(self.engine, key))(values[key]))

    def __getattr__(self, name):
        # the counters quantities read (inserted_count, removed_mass, ...) live in the engine object
        if name.startswith(("inserted_", "removed_")):
            return getattr(self.__dict__["engine"], name)
        raise AttributeError(name)


class Insert(_ParticleSetChange):
    """Particles inserted into a region at a rate, without overlaps (engine/insertion.py `Inserter`)."""

    kind = "insert"
    engine_class = insertion.Inserter

    def particle_types(self) -> list:
        return [self.engine.type]


class Outlet(_ParticleSetChange):
    """Particles whose centre is in a region removed at every `every` steps (engine/insertion.py `Outlet`)."""

    kind = "outlet"
    engine_class = insertion.Outlet


MODIFIERS = {cls.kind: cls for cls in (Gravity, Print, VtkDump, RestartWriter, Insert, Outlet)}


def create(fields: Fields, sim=None) -> Modifier:
    """A modifier of a create command; sim is the scene (the kinds that insert or remove particles read its
    materials and regions)."""
    name = fields.string("name", required=True)
    kind = fields.string("kind", required=True, choices=tuple(MODIFIERS))
    if issubclass(MODIFIERS[kind], _ParticleSetChange):
        return MODIFIERS[kind](name, fields, sim)
    return MODIFIERS[kind](name, fields)


def change_particles(sim) -> int:
    """Let the active insert and outlet modifiers act at the current step, in the order they were fixed;
    returns the change of the particle count."""
    before = sim.n
    for mod in sim.active_modifiers():
        mod.act(sim)
    return sim.n - before


def gravity_vector(active) -> np.ndarray:
    """Sum of the active modifiers' accelerations (m/s^2)."""
    g = np.zeros(3)
    for mod in active:
        a = mod.acceleration()
        if a is not None:
            g += a
    return g
