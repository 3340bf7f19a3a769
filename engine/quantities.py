"""Quantities a script can ask for (thermo columns, print files, `get`): a registry, after LAMMPS' computes.

A global quantity is a name and a function of the simulation; a per-particle quantity is ``NAME[ID]`` (e.g.
``vz[1]``), a per-wall one ``wall_fNAME[WALL]`` (e.g. ``wall_fz[floor]``). A new quantity is one entry of
`GLOBAL`. Sums over a selection of the particles are ``count|mass|ke|rke[type=T,region=NAME]`` (either or
both selectors; `SELECTED`), and the insert and outlet modifiers' counters ``inserted_count[NAME]``,
``inserted_mass``, ``removed_count``, ``removed_mass`` (`MODIFIER_COUNTERS`). Everything is vectorised numpy
over the particles, evaluated only at output steps.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from . import clumps, regions, superquadrics
from .errors import InputError
from .neighbor import overlap_statistics
from .script import AXES
from .walls import reference_points

#: overlaps above this fraction of the smaller radius are reported (issue 2)
OVERLAP_WARN_RATIO = 0.1


@dataclass(frozen=True)
class Quantity:
    unit: str
    doc: str
    value: object  # value(sim) -> int | float


def _speed_sq(s):
    return np.einsum("ij,ij->i", s.v, s.v)


def overlaps(sim):
    """(particle-particle contacts, contacts above 10 % overlap, max overlap / smaller radius)."""
    if sim.lo is None or len(sim.nbr.start) != sim.n + 1:
        return 0, 0, 0.0
    if sim.bodies is not None:  # members of one clump overlap by design: not contacts
        return clumps.overlaps(sim, OVERLAP_WARN_RATIO)
    return overlap_statistics(sim.state.x, sim.state.radius, sim.nbr.start, sim.nbr.j, sim.lo, sim.hi,
                              sim.periodic, OVERLAP_WARN_RATIO)


def _ke(sim, mask=slice(None)):
    if sim.superquadrics is not None and isinstance(mask, slice):  # all of a scene of superquadrics, which has
        return superquadrics.kinetic_energy(sim)  # no spheres (engine/superquadrics.py); selections pick spheres
    if sim.bodies is not None:  # a clump counts as its body (engine/clumps.py)
        return clumps.kinetic_energy(sim, mask)
    s = sim.state
    return float(0.5 * np.sum(s.mass[mask] * _speed_sq(s)[mask]))


def _rke(sim, mask=slice(None)):
    if sim.superquadrics is not None and isinstance(mask, slice):
        return superquadrics.rotational_energy(sim)
    if sim.bodies is not None:
        return clumps.rotational_energy(sim, mask)
    s = sim.state
    return float(0.5 * np.sum(0.4 * s.mass[mask] * s.radius[mask] ** 2
                              * np.einsum("ij,ij->i", s.omega, s.omega)[mask]))


def _pe(sim):
    if sim.bodies is not None or sim.superquadrics is not None:
        mass, x, _ = _bodies(sim)
        return float(-np.sum(mass * (x @ sim.gravity_vector())))
    return float(-np.sum(sim.state.mass * (sim.state.x @ sim.gravity_vector())))


def _bodies(sim):
    """(masses, positions, velocities): of the particles, or of the free spheres and clump bodies, or of the
    superquadrics."""
    if sim.superquadrics is not None:
        sq = sim.superquadrics
        return sq.mass, sq.x, sq.v
    if sim.bodies is not None:
        return clumps.masses_and_positions(sim)
    return sim.state.mass, sim.state.x, sim.state.v


def _momentum(axis):
    def value(sim):
        mass, _, v = _bodies(sim)
        return float(np.sum(mass * v[:, axis]))
    return value


def _com(axis):
    def value(sim):
        mass, x, _ = _bodies(sim)
        return float(np.sum(mass * x[:, axis]) / np.sum(mass)) if len(mass) else math.nan
    return value


def _selected_mass(sim, mask):
    if sim.bodies is not None:
        return float(np.sum(clumps.masses_and_positions(sim, mask)[0]))
    return float(np.sum(sim.state.mass[mask]))


GLOBAL = {
    "step": Quantity("-", "time step number", lambda sim: sim.step),
    "time": Quantity("s", "simulated time", lambda sim: sim.time),
    "atoms": Quantity("-", "number of particles (spheres, clump members or superquadrics)",
                      lambda sim: sim.n + superquadrics.count(sim)),
    "ke": Quantity("J", "translational kinetic energy, sum of m v^2 / 2", _ke),
    "rke": Quantity("J", "rotational kinetic energy, sum of I w^2 / 2 with I = 0.4 m r^2", _rke),
    "pe": Quantity("J", "gravitational potential energy, -sum of m x.g", _pe),
    "energy": Quantity("J", "ke + rke + pe", lambda sim: _ke(sim) + _rke(sim) + _pe(sim)),
    **{f"momentum_{a}": Quantity("kg m/s", f"total momentum along {a}", _momentum(k)) for a, k in AXES.items()},
    **{f"com_{a}": Quantity("m", f"centre of mass, {a}", _com(k)) for a, k in AXES.items()},
    "max_speed": Quantity("m/s", "largest particle speed",
                          lambda sim: float(np.sqrt(np.max(_speed_sq(sim.state)))) if sim.n else 0.0),
    "contacts": Quantity("-", "particle-particle contacts", lambda sim: overlaps(sim)[0]),
    "max_overlap": Quantity("-", "largest overlap / smaller radius", lambda sim: overlaps(sim)[2]),
    "lost": Quantity("-", "particles that left the fixed domain so far (not those an outlet removed)",
                     lambda sim: sim.lost_total),
}
GLOBAL_QUANTITIES = tuple(GLOBAL)

#: per particle: NAME[ID] -> (field of the state, component)
PARTICLE = {"x": ("x", 0), "y": ("x", 1), "z": ("x", 2), "vx": ("v", 0), "vy": ("v", 1), "vz": ("v", 2),
            "fx": ("f", 0), "fy": ("f", 1), "fz": ("f", 2), "omegax": ("omega", 0), "omegay": ("omega", 1),
            "omegaz": ("omega", 2)}
PARTICLE_QUANTITY = re.compile(r"^(%s)\[(\d+)\]$" % "|".join(PARTICLE))
#: force the particles exert on a wall (N) at the last step, e.g. wall_fz[floor], and its torque (N m) about the
#: wall's reference point (engine.walls.reference_points: a mesh's rotation point), e.g. wall_tz[drum]
WALL_QUANTITY = re.compile(r"^wall_([ft])([xyz])\[([^\]]+)\]$")


#: sums over the particles a selection picks: NAME[type=T], NAME[region=R] or NAME[type=T,region=R]
SELECTED = {
    "count": Quantity("-", "number of particles", lambda sim, mask: int(np.count_nonzero(mask))),
    "mass": Quantity("kg", "total mass", _selected_mass),
    "ke": Quantity("J", "translational kinetic energy", _ke),
    "rke": Quantity("J", "rotational kinetic energy", _rke),
}
SELECTED_QUANTITY = re.compile(r"^(%s)\[([^\]]+)\]$" % "|".join(SELECTED))
_SELECTOR = re.compile(r"^(type)=([1-9][0-9]*)$|^(region)=(.+)$")
#: counters of the insert and outlet modifiers: NAME[MODIFIER] -> (modifier kind, attribute)
MODIFIER_COUNTERS = {"inserted_count": ("insert", "inserted_count"), "inserted_mass": ("insert", "inserted_mass"),
                     "removed_count": ("outlet", "removed_count"), "removed_mass": ("outlet", "removed_mass")}
MODIFIER_QUANTITY = re.compile(r"^(%s)\[([^\]]+)\]$" % "|".join(MODIFIER_COUNTERS))


def selection(name: str):
    """(quantity, type or None, region name or None) of NAME[type=T,region=R], or None when name is not one
    (unknown selector, a selector twice, or neither)."""
    m = SELECTED_QUANTITY.match(name)
    if not m:
        return None
    chosen = {}
    for part in m.group(2).split(","):
        sel = _SELECTOR.match(part.strip())
        if not sel:
            return None
        key, value = (sel.group(1), int(sel.group(2))) if sel.group(1) else (sel.group(3), sel.group(4).strip())
        if key in chosen:
            return None
        chosen[key] = value
    return m.group(1), chosen.get("type"), chosen.get("region")


#: per clump: body_NAME[ID] (engine/clumps.py BODY_QUANTITIES), ID the body id from 1
BODY_QUANTITY = re.compile(r"^body_(%s)\[(\d+)\]$" % "|".join(clumps.BODY_QUANTITIES))
#: per superquadric: sq_NAME[ID] (engine/superquadrics.py QUANTITIES), ID its id from 1
SQ_QUANTITY = re.compile(r"^sq_(%s)\[(\d+)\]$" % "|".join(superquadrics.QUANTITIES))


def known(name: str) -> bool:
    return (name in GLOBAL or BODY_QUANTITY.match(name) is not None or PARTICLE_QUANTITY.match(name) is not None
            or SQ_QUANTITY.match(name) is not None
            or WALL_QUANTITY.match(name) is not None
            or selection(name) is not None or MODIFIER_QUANTITY.match(name) is not None)


def unknown_reference(sim, name: str) -> str | None:
    """Why quantity name cannot be evaluated in this scene (a region or modifier it names does not exist or
    is of another kind), or None. Per-wall quantities are checked by the run (`wall_names`)."""
    chosen = selection(name)
    if chosen is not None:
        region = chosen[2]
        if region is not None and region not in sim.regions:
            return (f"names no region '{region}' (regions: {', '.join(sorted(sim.regions)) or 'none'}; "
                    "create region first)")
        return None
    m = MODIFIER_QUANTITY.match(name)
    if m:
        kind = MODIFIER_COUNTERS[m.group(1)][0]
        mod = sim.modifiers.get(m.group(2))
        if mod is None or mod.kind != kind:
            names = sorted(n for n, mod in sim.modifiers.items() if mod.kind == kind)
            return (f"names no {kind} modifier '{m.group(2)}' ({kind} modifiers: {', '.join(names) or 'none'})")
    return None


def _selected(sim, name: str, chosen):
    quantity, ptype, region = chosen
    problem = unknown_reference(sim, name)
    if problem:
        raise InputError(f"quantity '{name}' {problem}")
    mask = np.ones(sim.n, dtype=bool)
    if ptype is not None:
        mask &= sim.state.ptype == ptype - 1
    if region is not None:
        mask &= regions.contains(sim.regions[region], sim.state.x)
    return SELECTED[quantity].value(sim, mask)


def evaluate(sim, name: str):
    """The value of a quantity now (NaN for a particle id that is not present)."""
    chosen = selection(name)
    if chosen is not None:
        return _selected(sim, name, chosen)
    m = MODIFIER_QUANTITY.match(name)
    if m:
        problem = unknown_reference(sim, name)
        if problem:
            raise InputError(f"quantity '{name}' {problem}")
        return getattr(sim.modifiers[m.group(2)], MODIFIER_COUNTERS[m.group(1)][1])
    m = WALL_QUANTITY.match(name)
    if m:
        names = [w["name"] for w in sim.walls]
        if m.group(3) not in names:
            raise InputError(f"quantity '{name}' names no wall '{m.group(3)}' (walls: {', '.join(names)})")
        k = names.index(m.group(3))
        if k >= len(sim.wall_force):
            return 0.0
        axis = AXES[m.group(2)]
        if m.group(1) == "f":
            return float(sim.wall_force[k, axis])
        # the kernel sums torques about the origin: about point p it is T_0 - p x F
        p = reference_points(sim)[k]
        return float(sim.wall_torque[k, axis] - np.cross(p, sim.wall_force[k])[axis])
    m = PARTICLE_QUANTITY.match(name)
    if m:
        where = np.nonzero(sim.state.pid == int(m.group(2)))[0]
        if len(where) == 0:
            return math.nan
        field, component = PARTICLE[m.group(1)]
        return float(getattr(sim.state, field)[where[0], component])
    m = BODY_QUANTITY.match(name)
    if m:
        return clumps.body_value(sim, m.group(1), int(m.group(2)))
    m = SQ_QUANTITY.match(name)
    if m:
        return superquadrics.value(sim, m.group(1), int(m.group(2)))
    if name in GLOBAL:
        return GLOBAL[name].value(sim)
    raise KeyError(name)


def wall_names(names) -> list:
    """(quantity, wall name) of the per-wall quantities among names."""
    return [(q, m.group(3)) for q in names for m in [WALL_QUANTITY.match(q)] if m]
