"""The particle state: every per-particle array declared once, held in one object passed whole to compiled code.

After jax-md's ``NVEState`` and HOOMD's ``ParticleData``: `PARTICLE_FIELDS` is the only list of the particle
arrays. Everything that handles "all particle arrays" - creating, appending, re-ordering at a neighbor rebuild,
dropping lost particles, the memory estimate, restart files - loops over it, so a new field is one line here.

`ParticleState` is a namedtuple of numpy arrays (Numba passes it to compiled functions as one argument and
keeps its type across calls, so the compiled code reads ``s.x``, ``s.radius`` ...). The fields a contact reads
and adds to of its partner are interleaved in blocks (`BLOCKS`), a row per particle (``s.xr``, ``s.hot``,
``s.acc``), so that a partner costs a few cache lines instead of one per field. ``s.x`` is a view of columns of
its block, in Python (a property) and in compiled code (an attribute overload) alike; the generated kernels index
the blocks directly (`interleaved`). The first axis of every array is the particle; compiled code works on the
first ``n`` rows (a rebuild that drops particles compacts the survivors to the front in place, and Python trims
the arrays to ``n`` afterwards: `trimmed`).

Types are numbered from 1 in scripts and from 0 in ``ptype``.
"""
from __future__ import annotations

import re
from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import literal_unroll, types
from numba.extending import overload_attribute

from .jit import content_key, njit


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

#: blocks of interleaved fields: block name -> (its fields in column order, doubles per row). In the pair pass a
#: partner j is a row in the middle of the particles, not the next one: each separate array it is read from costs
#: a cache line of its own, and at a million particles those lines come from beyond the L2 cache. `xr` holds what
#: the distance test of every listed pair reads of j (x, radius: 32 B, half a line), `hot` what a contact reads
#: besides (v, omega, mass: 56 B, one or two lines), `acc` what it adds to j (f, torque: 48 B, one or two lines):
#: three or four lines for a contact where separate arrays took seven. x and radius in `hot` as well made the
#: pair pass of falling spheres (listed pairs, few contacts) at 1,000,000 twice as slow: 88 B per partner where
#: 32 B are read. Wider rows measured slower at 1,000,000 too (1/m, 1/I and x_build in `hot`, or f and torque
#: with it; engine/README.md, "Particle layout"): the bytes between i and its farthest partner grow with the
#: row. The other fields keep an array each. Arithmetic does not depend on the layout: results are bitwise the
#: same.
BLOCKS = {"xr": (("x", "radius"), 4), "hot": (("v", "omega", "mass"), 7), "acc": (("f", "torque"), 6)}
#: field name -> (block, first column, columns, True for a scalar field)
COLUMNS = {}
for _block, (_names, _width) in BLOCKS.items():
    _first = 0
    for _name in _names:
        _field = next(f for f in PARTICLE_FIELDS if f.name == _name)
        COLUMNS[_name] = (_block, _first, int(np.prod(_field.shape)), _field.shape == ())
        _first += COLUMNS[_name][2]
    assert _first <= _width, _block
#: the arrays a state holds: the blocks, then the other fields
STORED = tuple(BLOCKS) + tuple(name for name in FIELD_NAMES if name not in COLUMNS)


def _view(block: np.ndarray, name: str) -> np.ndarray:
    _, first, width, scalar = COLUMNS[name]
    return block[:, first] if scalar else block[:, first:first + width]


ParticleState = type("ParticleState", (namedtuple("_StoredState", STORED),),
                     {"__slots__": (), "__module__": __name__,
                      "__doc__": "Per-particle arrays: a block per entry of BLOCKS, (n, doubles per row), its fields "
                                 "interleaved, and an array per other field; every field of PARTICLE_FIELDS reads as "
                                 "an attribute (a view into its block), in Python and in compiled code.",
                      **{name: property(lambda s, name=name: _view(getattr(s, COLUMNS[name][0]), name),
                                        doc=f"{name}: columns of {COLUMNS[name][0]} (a view)") for name in COLUMNS}})


def _attribute_in_compiled_code(name: str):
    """s.<name> in compiled code: the same view of its block the Python property gives."""
    block, first, width, scalar = COLUMNS[name]
    position = STORED.index(block)

    @overload_attribute(types.BaseNamedTuple, name)
    def view(s):
        if s.instance_class is ParticleState:
            if scalar:
                return lambda s: s[position][:, first]
            return lambda s: s[position][:, first:first + width]
        if name in s.fields:
            # an overload takes the attribute of every namedtuple: another one's own field of that name (a
            # WallSet's torque) is read as Numba reads fields, by position
            own = s.fields.index(name)
            return lambda s: s[own]
    return view


for _name in COLUMNS:
    _attribute_in_compiled_code(_name)
# engine/jit.py puts this in the key of machine code compiled for a state: the layout, and the code that makes
# s.x a view in compiled code (machine code keyed by the functions' own text alone would not see it change)
ParticleState.layout_key = f"{sorted(BLOCKS.items())} {content_key(_attribute_in_compiled_code)}"


#: an indexed read or write of an interleaved field in generated source: name[row] or name[row, column]
_INDEXED = re.compile(r"\b(" + "|".join(COLUMNS) + r")\[([A-Za-z_]\w*)(?:, ([0-9]))?\]")


def interleaved(code: str) -> str:
    """Generated source (engine/kernels.py) with every indexed access to an interleaved field, ``x[i, 1]`` or
    ``radius[j]``, made one to its block, ``xr[i, 1]`` or ``xr[j, 3]``: the same numbers. The views (``x =
    s.x``) are arrays of any layout to the compiler, each with its own base and strides; a C-ordered block
    indexed by constant columns is one base and one stride for all its fields (views alone made the pair pass of
    a dense bed 1.4 times as slow). The code must bind each block: ``hot = s.hot``."""
    def column(match):
        block, first, width, scalar = COLUMNS[match.group(1)]
        if match.group(3) is None and not scalar:
            return match.group(0)  # a whole row of a vector field: left to the view
        return f"{block}[{match.group(2)}, {first + int(match.group(3) or 0)}]"
    return _INDEXED.sub(column, code)


def pack(fields: dict) -> ParticleState:
    """The state holding these arrays (field name -> array, n rows each, every field of PARTICLE_FIELDS);
    copies."""
    n = len(fields["pid"])
    stored = {block: np.zeros((n, width)) for block, (_, width) in BLOCKS.items()}
    for f in PARTICLE_FIELDS:
        value = np.asarray(fields[f.name], dtype=f.dtype)
        if f.name in COLUMNS:
            block, first, width, _ = COLUMNS[f.name]
            stored[block][:, first:first + width] = value.reshape(n, width)
        else:
            stored[f.name] = np.ascontiguousarray(value)
    return ParticleState(**stored)


def _shape(field: Field, n: int, walls: int = 0, history: int = 0) -> tuple:
    return (n,) + tuple(walls if d == "walls" else history if d == "history" else d for d in field.shape)


def empty(walls: int = 0, history: int = 0) -> ParticleState:
    """A state without particles."""
    return pack({f.name: np.zeros(_shape(f, 0, walls, history), dtype=f.dtype) for f in PARTICLE_FIELDS})


def append(state: ParticleState, **values) -> ParticleState:
    """state with new particles at the end; values: an array per field (n rows), missing fields are zero."""
    n = len(values["x"])
    out = {}
    for f in PARTICLE_FIELDS:
        old = getattr(state, f.name)
        new = values.get(f.name)
        if new is None:
            new = np.zeros((n,) + old.shape[1:], dtype=f.dtype)
        out[f.name] = np.concatenate([old, np.asarray(new, dtype=f.dtype).reshape((n,) + old.shape[1:])])
    return pack(out)


def count(state: ParticleState) -> int:
    return len(state.pid)


def trimmed(state: ParticleState, n: int) -> ParticleState:
    """The first n particles (views, no copy): what compiled code left after dropping lost particles."""
    if n == count(state):
        return state
    return ParticleState._make(a[:n] for a in state)


def take(state: ParticleState, index) -> ParticleState:
    """A new state of the particles index selects (copies)."""
    return pack({name: getattr(state, name)[index] for name in FIELD_NAMES})


def bytes_per_particle(walls: int, history: int) -> int:
    """Bytes one particle holds in the state arrays (with `walls` walls and `history` doubles per contact)."""
    return 8 * sum(width for _, width in BLOCKS.values()) + sum(
        np.dtype(f.dtype).itemsize * int(np.prod(_shape(f, 1, walls, history)))
        for f in PARTICLE_FIELDS if f.name not in COLUMNS)


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
    return {name: getattr(state, name) for name in FIELD_NAMES}


def from_arrays(arrays: dict) -> ParticleState:
    """The state of a restart file's arrays (checked by the caller)."""
    return pack(arrays)


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
