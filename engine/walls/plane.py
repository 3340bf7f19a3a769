"""Plane walls: a point and a unit normal (any direction), two-sided, optionally bounded to a box the contact
point must lie in, moving at a velocity (the point moves with its whole velocity; the part along the plane only
shears the contacts, a conveyor)."""
from __future__ import annotations

import numpy as np

from ..script import Fields
from ..state import BLOCKS
from ..templates import render, unpack
from .shape import AXES, KernelPart, WallShape, numbers, rows, unit

#: a wall has infinite radius and mass (R* = r_i, m* = m_i), its type's material; en points from the wall to
#: the particle. A plane along an axis gives bitwise the values of a plane that knows its axis: (x - p).n adds
#: exact zeros, and + 0.0 turns the -0.0 of sign * 0.0 into +0.0.
PLANE_CONTACTS = """\
near = plane_near[i]
for w in range(nplanes if near != 0 or nplanes > PLANE_BITS else 0):  # near == 0: none in reach, nothing to test
    if w < PLANE_BITS and (near >> w) & 1 == 0:
        continue  # out of reach since the last rebuild: no contact, no history (PLANE_REACH)
    nx = plane_normal[w, 0]
    ny = plane_normal[w, 1]
    nz = plane_normal[w, 2]
    sep = (xi0 - plane_point[w, 0]) * nx + (xi1 - plane_point[w, 1]) * ny + (xi2 - plane_point[w, 2]) * nz
    dist = abs(sep)
    if dist >= ri:
        ${reset_history}
        continue
    ${bounds}
    sign = 1.0 if sep >= 0.0 else -1.0
    enx = sign * nx + 0.0
    eny = sign * ny + 0.0
    enz = sign * nz + 0.0
    d = ri - dist
    tj = plane_type[w]
    vrx = vix - plane_vel[w, 0]
    vry = viy - plane_vel[w, 1]
    vrz = viz - plane_vel[w, 2]
    vn = vrx * enx + vry * eny + vrz * enz
    ${contact}
"""
#: the planes a particle can touch before the next rebuild: its centre at the last rebuild (x_build) nearer than
#: r + skin to the plane, since it moves at most skin/2 before the next rebuild (bit w of plane_near[i] for the
#: first PLANE_BITS planes; planes after them, and planes moving along their normal, are always tested). A plane
#: out of reach has no contact at any force evaluation until the next rebuild, so its history is zero: set
#: here once, as each of those evaluations would set it. Recomputed after every rebuild and at every start of
#: run_steps (walls may have changed between runs), from x_build: the same bits on any thread count and after
#: a restart.
PLANE_REACH = '''\
#: planes whose reach is kept as bits of one int64 per particle (plane_reach)
PLANE_BITS = 62


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def plane_reach(s, n, walls, skin, plane_near):
    """Bits of the planes within r + skin of each particle's centre at the last rebuild (see the template)."""
    ${unpack}
    nplanes = min(plane_point.shape[0], PLANE_BITS)
    for i in prange(n):
        near = 0
        reach = radius[i] + skin
        for w in range(nplanes):
            nx = plane_normal[w, 0]
            ny = plane_normal[w, 1]
            nz = plane_normal[w, 2]
            moving = plane_vel[w, 0] * nx + plane_vel[w, 1] * ny + plane_vel[w, 2] * nz != 0.0
            sep = ((x_build[i, 0] - plane_point[w, 0]) * nx + (x_build[i, 1] - plane_point[w, 1]) * ny
                   + (x_build[i, 2] - plane_point[w, 2]) * nz)
            if moving or abs(sep) < reach:
                near |= 1 << w
            else:
                for h in range(wall_hist.shape[2]):
                    wall_hist[i, w, h] = 0.0
        plane_near[i] = near
'''
PLANE_REACH_CALL = "plane_near = np.empty(n, dtype=np.int64)\nplane_reach(s, n, walls, skin, plane_near)\n"
NO_PLANE_REACH = "plane_near = np.empty(0, dtype=np.int64)\n"

#: a bounded plane: contact only where the foot of the centre lies in the box lo..hi
PLANE_BOUNDS = """\
fx0 = xi0 - sep * nx
fx1 = xi1 - sep * ny
fx2 = xi2 - sep * nz
if (fx0 < plane_lo[w, 0] or fx0 > plane_hi[w, 0] or fx1 < plane_lo[w, 1] or fx1 > plane_hi[w, 1]
        or fx2 < plane_lo[w, 2] or fx2 > plane_hi[w, 2]):
    ${reset_history}
    continue
"""
#: the planes' points move with their velocity (each step, as LIGGGHTS' fix wall/gran moves its walls)
MOVE_PLANES = """\
for w in range(walls.plane_point.shape[0]):
    for a in range(3):
        walls.plane_point[w, a] += walls.plane_vel[w, a] * dt
"""


def _bounds(w, key, default):
    b = w.get("bounds")
    return b[key] if b else [default] * 3


class Plane(WallShape):
    name = "plane"
    #: point (m, 3, moves), unit normal, velocity (m/s, 3), type (0-based), bounds lo/hi of the contact point
    #: (m, 3; +-inf when unbounded)
    fields = ("plane_point", "plane_normal", "plane_vel", "plane_type", "plane_lo", "plane_hi")
    features = ("planes", "bounded_planes")

    def parse(self, sim, fields, wall):
        if fields.has("axis") or fields.has("position"):  # an axis plane: the point on that axis
            axis = AXES[fields.string("axis", required=True, choices=tuple(AXES))]
            position = fields.number("position", required=True)
            wall["point"] = [position if a == axis else 0.0 for a in range(3)]
            wall["normal"] = [1.0 if a == axis else 0.0 for a in range(3)]
        else:
            wall["point"] = fields.vector("point", required=True)
            wall["normal"] = unit(fields, "normal", required=True)
        wall["velocity"] = fields.vector("velocity", default=[0.0, 0.0, 0.0])
        bounds = fields.mapping("bounds")
        if bounds is not None:
            sub = Fields(bounds, fields.where + ", bounds")
            lo, hi = sub.vector("lo", required=True), sub.vector("hi", required=True)
            if any(h < l for l, h in zip(lo, hi)):
                raise sub.error("hi", "must be >= 'lo' on every axis")
            sub.finish()
            wall["bounds"] = dict(lo=lo, hi=hi)
        return None

    def valid(self, w):
        return numbers(w.get("point"), 3) and numbers(w.get("normal"), 3) and numbers(w.get("velocity"), 3)

    def arrays(self, sim, walls):
        return dict(plane_point=sim.plane_point, plane_normal=rows([w["normal"] for w in walls]),
                    plane_vel=rows([w["velocity"] for w in walls]),
                    plane_type=np.array([w["type"] - 1 for w in walls], dtype=np.int64),
                    plane_lo=rows([_bounds(w, "lo", -np.inf) for w in walls]),
                    plane_hi=rows([_bounds(w, "hi", np.inf) for w in walls]))

    def flags(self, walls):
        return dict(planes=bool(walls), bounded_planes=any(w.get("bounds") for w in walls))

    def speed(self, sim, w):
        return float(np.linalg.norm(w["velocity"]))

    def reference_points(self, sim, walls):
        return list(sim.plane_point)

    def gaps(self, sim, walls, x, radius):
        """r - |(x - p).n| (two-sided; outside its bounds: no contact), as distances |(x - p).n| - r."""
        gaps = []
        for w, p in zip(walls, sim.plane_point):
            sep = (x - p) @ np.asarray(w["normal"])
            gap = np.abs(sep) - radius
            if w.get("bounds"):
                foot = x - np.outer(sep, w["normal"])
                inside = np.all((foot >= w["bounds"]["lo"]) & (foot <= w["bounds"]["hi"]), axis=1)
                gap = np.where(inside, gap, np.inf)
            gaps.append(gap)
        return gaps

    def restore_motion(self, sim, old_walls, walls):
        old_points = dict(zip((w["name"] for w in old_walls), sim.plane_point))
        sim.plane_point = rows([old_points.get(w["name"], w["point"]) for w in walls])

    def kernel(self, c):
        if not c.planes:
            return KernelPart(at_start=NO_PLANE_REACH, setup=NO_PLANE_REACH)

        def contacts(contact, reset):
            bounds = render(PLANE_BOUNDS, reset_history=reset("wall")) if c.bounded_planes else ""
            return render(PLANE_CONTACTS, reset_history=reset("wall"), contact=contact("wall"), bounds=bounds)
        return KernelPart(contacts=contacts, move=MOVE_PLANES, after_rebuild=PLANE_REACH_CALL,
                          at_start=PLANE_REACH_CALL, setup=PLANE_REACH_CALL,
                          functions=render(PLANE_REACH, unpack=unpack("s", tuple(BLOCKS) + ("x_build", "radius", "wall_hist"))
                                           + unpack("walls", ("plane_point", "plane_normal", "plane_vel"))))
