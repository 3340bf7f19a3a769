"""The particle state: every per-particle array declared once, held in one object passed whole to compiled code.

After jax-md's ``NVEState`` and HOOMD's ``ParticleData``: `PARTICLE_FIELDS` is the only list of the particle
arrays. Everything that handles "all particle arrays" - creating, appending, re-ordering at a neighbor rebuild,
dropping lost particles, the memory estimate, restart files - loops over it, so a new field is one line here.

`ParticleState` is a namedtuple of numpy arrays (Numba passes it to compiled functions as one argument and
keeps its type across calls, so the compiled code reads ``s.x``, ``s.radius`` ...). The first axis of every
array is the particle; compiled code works on the first ``n`` rows (a rebuild that drops particles compacts the
survivors to the front in place, and Python trims the arrays to ``n`` afterwards: `trimmed`).

Types are numbered from 1 in scripts and from 0 in ``ptype``.
"""
from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import literal_unroll

from .jit import njit


@dataclass(frozen=True)
class Field:
    """One per-particle array: name, dtype, shape of one particle's entry, unit and meaning."""

    name: str
    dtype: type
    shape: tuple
    unit: str
    doc: str


#: ``("walls", "history")`` in a shape means: one row per wall, one column per history double of the contact
#: model; it is fixed when a run starts (`fit_wall_history`).
PARTICLE_FIELDS = (
    Field("x", np.float64, (3,), "m", "position"),
    Field("v", np.float64, (3,), "m/s", "velocity"),
    Field("f", np.float64, (3,), "N", "force of the last force evaluation (gravity, contacts, walls)"),
    Field("omega", np.float64, (3,), "rad/s", "angular velocity"),
    Field("torque", np.float64, (3,), "N m", "torque of the last force evaluation"),
    Field("radius", np.float64, (), "m", "radius"),
    Field("mass", np.float64, (), "kg", "mass"),
    Field("inv_mass", np.float64, (), "1/kg", "1 / mass"),
    Field("inv_inertia", np.float64, (), "1/(kg m^2)", "1 / (0.4 m r^2), solid sphere"),
    Field("ptype", np.int64, (), "-", "material type, 0-based"),
    Field("pid", np.int64, (), "-", "particle id, from 1, never reused"),
    Field("x_build", np.float64, (3,), "m", "position at the last neighbor rebuild"),
    Field("wall_hist", np.float64, ("walls", "history"), "-", "contact history with each plane and cylinder "
                                                              "(e.g. shear displacement, m; meshes keep theirs "
                                                              "in engine.mesh.MeshList)"),
)

FIELD_NAMES = tuple(f.name for f in PARTICLE_FIELDS)
ParticleState = namedtuple("ParticleState", FIELD_NAMES)
ParticleState.__doc__ = "Per-particle arrays, one per entry of engine.state.PARTICLE_FIELDS."


def _shape(field: Field, n: int, walls: int = 0, history: int = 0) -> tuple:
    return (n,) + tuple(walls if d == "walls" else history if d == "history" else d for d in field.shape)


def empty(walls: int = 0, history: int = 0) -> ParticleState:
    """A state without particles."""
    return ParticleState._make(np.zeros(_shape(f, 0, walls, history), dtype=f.dtype) for f in PARTICLE_FIELDS)


def append(state: ParticleState, **values) -> ParticleState:
    """state with new particles at the end; values: an array per field (n rows), missing fields are zero."""
    n = len(values["x"])
    out = []
    for f, old in zip(PARTICLE_FIELDS, state):
        new = values.get(f.name)
        if new is None:
            new = np.zeros((n,) + old.shape[1:], dtype=f.dtype)
        out.append(np.ascontiguousarray(np.concatenate([old, np.asarray(new, dtype=f.dtype).reshape(
            (n,) + old.shape[1:])])))
    return ParticleState._make(out)


def count(state: ParticleState) -> int:
    return len(state.pid)


def trimmed(state: ParticleState, n: int) -> ParticleState:
    """The first n particles (views, no copy): what compiled code left after dropping lost particles."""
    if n == count(state):
        return state
    return ParticleState._make(a[:n] for a in state)


def take(state: ParticleState, index) -> ParticleState:
    """A new state of the particles index selects (copies)."""
    return ParticleState._make(np.ascontiguousarray(a[index]) for a in state)


def bytes_per_particle(walls: int, history: int) -> int:
    """Bytes one particle holds in the state arrays (with `walls` walls and `history` doubles per contact)."""
    return sum(np.dtype(f.dtype).itemsize * int(np.prod(_shape(f, 1, walls, history))) for f in PARTICLE_FIELDS)


def fit_wall_history(state: ParticleState, walls: int, history: int) -> ParticleState:
    """state whose wall history has one row per wall and `history` columns: kept where the shape already fits
    (a continued run), zeros otherwise (new walls or a new contact model start without history)."""
    old = state.wall_hist
    width = history if walls else 0
    rows = walls if width else 0
    if old.shape[1:] == (rows, width):
        return state
    return state._replace(wall_hist=np.zeros((count(state), rows, width)))


def as_arrays(state: ParticleState) -> dict:
    """Field name -> array (restart files store the fields under their names)."""
    return dict(zip(FIELD_NAMES, state))


def from_arrays(arrays: dict) -> ParticleState:
    """The state of a restart file's arrays (checked by the caller)."""
    return ParticleState._make(np.ascontiguousarray(arrays[name], dtype=f.dtype)
                               for name, f in zip(FIELD_NAMES, PARTICLE_FIELDS))


# ---------------------------------------------------------------- compiled: re-ordering at a rebuild

@njit(cache=True)
def _reorder_rows(a, order, n):
    a[:n] = a[order]


@njit(cache=True)
def reorder(state, order):
    """Every field's rows put in `order` (in place; n = len(order) <= rows: lost particles fall off the end)."""
    n = order.shape[0]
    for a in literal_unroll(state):
        _reorder_rows(a, order, n)
