"""The wall set: every wall of a scene as one object of arrays, passed whole to compiled code.

Plane walls come first, then z-cylinders; a wall's index in `WallSet.force` (and in the particles' wall
history) is its place in that order. Wall definitions as the script gives them stay plain dicts (name, shape,
type, axis/position/velocity or center/radius/side) so that restart files can store them as JSON.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

#: plane_axis (0, 1, 2), plane_pos (m, moves with the axial velocity), plane_vel (m/s, 3), plane_type (0-based);
#: cyl_center (m, 2), cyl_radius (m), cyl_side (+1 inside, -1 outside), cyl_type (0-based); force: the force
#: the particles exert on each wall (N, 3) at the last step of a chunk
WALL_FIELDS = ("plane_axis", "plane_pos", "plane_vel", "plane_type", "cyl_center", "cyl_radius", "cyl_side",
               "cyl_type", "force")
WallSet = namedtuple("WallSet", WALL_FIELDS)


def ordered(walls: list[dict]) -> list[dict]:
    """Planes first, then cylinders (the order of the wall history columns and of WallSet.force)."""
    return [w for w in walls if w["shape"] == "plane"] + [w for w in walls if w["shape"] == "cylinder"]


def wall_set(walls: list[dict], plane_pos: np.ndarray, force: np.ndarray) -> WallSet:
    """The arrays of `walls` (already ordered); plane_pos and force are used as they are (they carry state)."""
    planes = [w for w in walls if w["shape"] == "plane"]
    cylinders = [w for w in walls if w["shape"] == "cylinder"]
    return WallSet(
        plane_axis=np.array([w["axis"] for w in planes], dtype=np.int64),
        plane_pos=plane_pos,
        plane_vel=np.array([w["velocity"] for w in planes], dtype=np.float64).reshape(-1, 3),
        plane_type=np.array([w["type"] - 1 for w in planes], dtype=np.int64),
        cyl_center=np.array([w["center"] for w in cylinders], dtype=np.float64).reshape(-1, 2),
        cyl_radius=np.array([w["radius"] for w in cylinders], dtype=np.float64),
        cyl_side=np.array([1.0 if w["side"] == "inside" else -1.0 for w in cylinders], dtype=np.float64),
        cyl_type=np.array([w["type"] - 1 for w in cylinders], dtype=np.int64),
        force=force)


def overlap_ratios(walls: list[dict], plane_pos, x, radius) -> np.ndarray:
    """(walls, particles) overlap / radius, > 0 where a particle overlaps a wall (vectorised).

    Plane along axis a at p: overlap r - |x_a - p| (two-sided); z-cylinder: r - (R - rho) inside,
    r - (rho - R) outside, rho the distance from its axis (physics.md, walls).
    """
    gaps = []
    planes = [w for w in walls if w["shape"] == "plane"]
    for w, p in zip(planes, plane_pos):
        gaps.append(np.abs(x[:, w["axis"]] - p) - radius)
    for w in (w for w in walls if w["shape"] == "cylinder"):
        rho = np.hypot(x[:, 0] - w["center"][0], x[:, 1] - w["center"][1])
        gap = (w["radius"] - rho) if w["side"] == "inside" else (rho - w["radius"])
        gaps.append(gap - radius)
    return -np.array(gaps) / radius
