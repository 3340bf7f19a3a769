"""The script's superquadric objects: `create superquadric`, `create superquadric_packing`
(engine/superquadrics.py).

Fields are in engine/README.md (*Superquadrics*): `type`, `half_axes` [a, b, c] (m), `blockiness` [n1, n2]
or one number for both (2 = ellipsoid, up to 10), `position` (m), `orientation` (body frame -> space, as for
clumps: `{"axis": [...], "angle": degrees}` or `{"quaternion": [w, x, y, z]}`), `velocity`, `omega`.
"""
from __future__ import annotations

import math

import numpy as np

from . import clumps, superquadrics
from .clump_commands import _material, orientation_of
from .errors import RunFailure
from .regions import region_of
from .scene import random_packing
from .script import Fields

#: blockiness a script may give: 2 (ellipsoid) to this; above it the shape function's powers overflow soon
MAX_BLOCKINESS = 20.0


def _shape(sim, fields: Fields) -> superquadrics.Shape:
    if sim.lo is not None and np.any(sim.periodic):
        raise fields.error("type", "superquadrics need a domain without periodic axes")
    t = _material(sim, fields)
    axes = fields.vector("half_axes", required=True)
    if not all(v > 0 for v in axes):
        raise fields.error("half_axes", f"must be three lengths > 0 (m), got {axes}")
    raw = fields.raw("blockiness", 2.0)
    values = raw if isinstance(raw, list) else [raw, raw]
    if not (len(values) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                                     and 2.0 <= v <= MAX_BLOCKINESS for v in values)):
        raise fields.error("blockiness", f"must be a number or [n1, n2], each from 2 to {MAX_BLOCKINESS:g}, "
                           f"got {raw!r}")
    return superquadrics.Shape(t, axes, values, sim.materials[t][2])


def create_superquadric(sim, fields: Fields):
    shape = _shape(sim, fields)
    position = np.array(fields.vector("position", required=True))
    q = orientation_of(fields)
    superquadrics.add(sim, shape, position[None, :], q[None, :], fields.vector("velocity", default=[0, 0, 0]),
                      fields.vector("omega", default=[0, 0, 0]))


def create_superquadric_packing(sim, fields: Fields):
    """count superquadrics of one shape at random positions in a region (their bounding spheres overlap
    nothing there), random orientations (uniform; Shoemake), from seed."""
    shape = _shape(sim, fields)
    count = fields.integer("count", required=True, minimum=1)
    seed = fields.integer("seed", required=True, minimum=0)
    attempts = fields.integer("max_attempts", 200, minimum=1)
    region = region_of(fields, sim.regions)
    sq = sim.superquadrics
    existing_x = sq.x if sq is not None else np.zeros((0, 3))
    existing_r = sq.radius if sq is not None else np.zeros(0)
    points = random_packing(region, np.full(count, shape.radius), seed, existing_x, existing_r, attempts)
    if len(points) < count:
        raise RunFailure(f"{fields.where}: placed only {len(points)} of {count} superquadrics without overlap in "
                         f"{attempts} attempts each; enlarge the region or lower 'count'")
    q = clumps.random_quaternions(np.random.Generator(np.random.PCG64([seed, 3])), count)
    superquadrics.add(sim, shape, points, q, fields.vector("velocity", default=[0, 0, 0]),
                      fields.vector("omega", default=[0, 0, 0]))
    sim.log.info(f"created {count} superquadrics (half-axes {[shape.a, shape.b, shape.c]} m, blockiness "
                 f"{[shape.n1, shape.n2]}, mass {shape.mass!r} kg) by random packing (seed {seed})")


CREATE = {"superquadric": create_superquadric, "superquadric_packing": create_superquadric_packing}
