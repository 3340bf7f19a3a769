"""The wall set: every wall of a scene as one object of arrays, passed whole to compiled code.

Walls come in shapes, each a class that owns its script fields, arrays, kernel code, surface speed and restart
check (`engine.walls.shape.WallShape`): `SHAPES` lists them in their order - planes, cylinders, meshes (a wall's
index in `WallSet.force`, `WallSet.torque` and the particles' dense wall history is its place in that order).
A new shape is one class in its own module and one entry in `SHAPES`.

Wall definitions as the script gives them stay plain dicts (JSON in restart files); what moves is held by the
Simulation as arrays (plane points, mesh angles and shifts) that the compiled step loop advances in place.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..jit import njit
from .cylinder import Cylinder
from .mesh_wall import Mesh
from .plane import Plane

SHAPES = {shape.name: shape for shape in (Plane(), Cylinder(), Mesh())}

#: the shapes' arrays, then force, torque: force (N) and torque about the origin (N m) the particles exert on
#: each wall, at the last step of a chunk
WALL_FIELDS = tuple(name for shape in SHAPES.values() for name in shape.fields) + ("force", "torque")
WallSet = namedtuple("WallSet", WALL_FIELDS)
#: the flags of compiled code the shapes ask for (engine.kernels.Combination fields)
WALL_FEATURES = tuple(name for shape in SHAPES.values() for name in shape.features)


def ordered(walls: list[dict]) -> list[dict]:
    """In the order of SHAPES (the order of the wall history columns and of WallSet.force)."""
    return [w for shape in SHAPES for w in walls if w["shape"] == shape]


def of_shape(walls: list[dict], shape: str) -> list[dict]:
    return [w for w in walls if w["shape"] == shape]


def dense_count(walls: list[dict]) -> int:
    """Walls whose contact history each particle keeps densely (planes and cylinders; meshes keep theirs in
    the sparse list)."""
    return sum(1 for w in walls if SHAPES[w["shape"]].dense_history)


def valid(w) -> bool:
    """w is a wall definition (as a restart file holds it)."""
    return (isinstance(w, dict) and isinstance(w.get("name"), str) and isinstance(w.get("type"), int)
            and w.get("shape") in SHAPES and SHAPES[w["shape"]].valid(w))


def set_walls(sim, walls: list[dict], triangles: dict | None = None):
    """sim's walls (ordered), keeping what moved (plane points, mesh angles and shifts) by wall name."""
    old = sim.walls
    sim.walls = ordered(walls)
    sim.mesh_triangles.update(triangles or {})
    for name, shape in SHAPES.items():
        shape.restore_motion(sim, of_shape(old, name), of_shape(sim.walls, name))


def wall_set(sim) -> WallSet:
    """The arrays of sim's walls (already ordered); sim's plane points, mesh angles and shifts, wall forces and
    torques are used as they are (they carry state between runs)."""
    arrays = {}
    for name, shape in SHAPES.items():
        arrays.update(shape.arrays(sim, of_shape(sim.walls, name)))
    return WallSet(force=sim.wall_force, torque=sim.wall_torque, **arrays)


def features(walls: list[dict]) -> dict:
    """Which wall code a scene needs compiled (engine.kernels.Combination fields)."""
    flags = {}
    for name, shape in SHAPES.items():
        flags.update(shape.flags(of_shape(walls, name)))
    return flags


def reference_points(sim) -> np.ndarray:
    """(walls, 3) the point each wall's torque is taken about (m): a plane's current point, a cylinder's axis
    point, a mesh's rotation point (the origin without a rotation), moved with the mesh."""
    points = [p for name, shape in SHAPES.items() for p in shape.reference_points(sim, of_shape(sim.walls, name))]
    return np.array(points, dtype=np.float64).reshape(-1, 3)


def surface_speeds(sim) -> list:
    """The largest speed (m/s) of each wall's surface: a plane's velocity, omega R of a turning cylinder, a
    mesh's |v| + |omega| (farthest corner from its axis)."""
    return [SHAPES[w["shape"]].speed(sim, w) for w in sim.walls]


def overlap_ratios(sim, x=None, radius=None) -> np.ndarray:
    """(walls, particles) overlap / radius, > 0 where a particle overlaps a wall (sim's particles, or spheres at
    x (m, n x 3) with radius (m, n)): r minus the distance to the wall's surface (each shape's `gaps`;
    physics.md, walls; engine/mesh.py)."""
    if x is None:
        x, radius = sim.state.x, sim.state.radius
    gaps = [g for name, shape in SHAPES.items() for g in shape.gaps(sim, of_shape(sim.walls, name), x, radius)]
    return -np.array(gaps).reshape(-1, len(x)) / radius


@njit(cache=True, error_model="numpy")
def collect_wall_forces(wall_force, wall_torque, wall_part, wall_tpart):
    """The force (N) and torque about the origin (N m) the particles exert on each wall: minus what each
    particle's contacts left in wall_part and wall_tpart (particle, wall, axis), added in increasing particle
    index - the order of a serial loop, so the same bytes on any number of threads."""
    wall_force[:, :] = 0.0
    wall_torque[:, :] = 0.0
    for i in range(wall_part.shape[0]):
        for w in range(wall_part.shape[1]):
            for a in range(3):
                wall_force[w, a] -= wall_part[i, w, a]
                wall_torque[w, a] -= wall_tpart[i, w, a]
