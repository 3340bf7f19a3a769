"""The contract of a wall shape (`WallShape`) and the script helpers the shapes share."""
from __future__ import annotations

import math

import numpy as np

from ..script import AXES


class WallShape:
    """One kind of wall. A shape owns everything about its walls:

    - `name` (the script's `shape`), `parse` (its fields of `create wall` into the wall's dict, the JSON a
      restart file keeps) and `valid` (the check of such a dict read back from a restart file);
    - `fields`: the arrays it puts into the `WallSet` compiled code receives, made by `arrays`;
    - `features`: the flags of the compiled code it asks for (fields of `engine.kernels.Combination`, all
      booleans, set by `flags`), and `kernel`: its part of the generated kernels for a combination;
    - `speed` (the fastest point of a wall's surface, m/s, for the critical time step), `reference_point` (what
      its torque is taken about) and `gaps` (distance of particles from each wall's surface);
    - what moves between runs (`moving_state` / `restore_motion`).

    `dense_history`: each particle keeps its history with such a wall in its dense row (planes, cylinders);
    meshes keep theirs in their sparse contact list.
    """

    name = ""
    fields: tuple = ()
    features: tuple = ()
    dense_history = True

    def parse(self, sim, fields, wall: dict):
        """Read the shape's fields into wall; returns the placed triangles of a mesh, else None."""
        raise NotImplementedError

    def valid(self, w: dict) -> bool:
        raise NotImplementedError

    def arrays(self, sim, walls: list) -> dict:
        raise NotImplementedError

    def flags(self, walls: list) -> dict:
        raise NotImplementedError

    def speed(self, sim, w: dict) -> float:
        raise NotImplementedError

    def reference_points(self, sim, walls: list) -> list:
        raise NotImplementedError

    def gaps(self, sim, walls: list, x, radius) -> list:
        raise NotImplementedError

    def restore_motion(self, sim, old_walls: list, walls: list):
        """Keep, by wall name, what moved of walls that stay (sim's arrays for walls of this shape)."""

    def kernel(self, c) -> "KernelPart":
        return KernelPart()


class KernelPart:
    """A shape's part of the generated kernels (engine.kernels): `contacts(contact, reset)` its contacts in the
    particle pass (contact: the contact code for a dense wall contact, reset: the history reset), `contacts_mesh`
    for a shape with its own contact code; `move` per step in the step loop; `travel` (adds to `need` when the
    shape moved too far since the last rebuild), `after_rebuild` (after a rebuild in the step loop), `at_start` (the start of
    a step loop) and `setup` (after the rebuild of setup); `functions`: compiled functions it adds to the module; `calls`: the functions it imports."""

    def __init__(self, contacts=None, move="", travel="", after_rebuild="", at_start="", setup="", functions="",
                 calls=()):
        self.contacts = contacts or (lambda contact, reset: "")
        self.move = move
        self.travel = travel
        self.after_rebuild = after_rebuild
        self.at_start = at_start
        self.setup = setup
        self.functions = functions
        self.calls = tuple(calls)


def numbers(value, k) -> bool:
    """value is a list of k finite numbers (not booleans)."""
    return isinstance(value, list) and len(value) == k and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)


def unit(fields, name: str, default=None, required=False):
    """A direction: a vector of 3 numbers, not zero, returned as a unit vector (the given one divided by its
    length; an exact axis stays exact)."""
    value = fields.vector(name, default=default, required=required)
    if value is None:
        return None
    norm = math.sqrt(sum(v * v for v in value))
    if not (norm > 0.0 and math.isfinite(norm)):
        raise fields.error(name, f"must be a direction (a non-zero vector), got {value}")
    return [v / norm for v in value]


def axis_or_vector(fields, name: str, required=False):
    """'x', 'y', 'z' or a vector: a unit direction."""
    value = fields.raw(name)
    if isinstance(value, str):
        axis = AXES[fields.string(name, choices=tuple(AXES))]
        return [1.0 if a == axis else 0.0 for a in range(3)]
    return unit(fields, name, required=required)


def rows(values, width=3) -> np.ndarray:
    """A (k, width) float64 array of k rows (also for k = 0)."""
    return np.array(values, dtype=np.float64).reshape(-1, width)
