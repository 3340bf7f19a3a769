"""Cylinder walls: a point on the axis, the unit axis, a radius, contact inside or outside, optionally limited to
an extent along the axis; the surface may turn about the axis at an angular velocity (a drum): the shape stays,
the surface moves at omega R tangentially."""
from __future__ import annotations

import numpy as np

from ..templates import render
from .shape import KernelPart, WallShape, axis_or_vector, numbers, rows

#: en points inward for an inside wall, outward outside; rho the distance from the axis (for the z axis through
#: (cx, cy, 0) bitwise sqrt((x - cx)^2 + (y - cy)^2))
CYLINDER_CONTACTS = """\
for q in range(cyl_radius.shape[0]):
    w = nplanes + q
    px = xi0 - cyl_point[q, 0]
    py = xi1 - cyl_point[q, 1]
    pz = xi2 - cyl_point[q, 2]
    ax = cyl_axis[q, 0]
    ay = cyl_axis[q, 1]
    az = cyl_axis[q, 2]
    along = px * ax + py * ay + pz * az
    ${extent}
    rx = px - along * ax
    ry = py - along * ay
    rz = pz - along * az
    rho = sqrt(rx * rx + ry * ry + rz * rz)
    if cyl_side[q] > 0:
        dist = cyl_radius[q] - rho
    else:
        dist = rho - cyl_radius[q]
    if dist >= ri or rho == 0.0:
        ${reset_history}
        continue
    enx = -cyl_side[q] * rx / rho + 0.0
    eny = -cyl_side[q] * ry / rho + 0.0
    enz = -cyl_side[q] * rz / rho + 0.0
    d = ri - dist
    tj = cyl_type[q]
    ${surface_velocity}
    vn = vrx * enx + vry * eny + vrz * enz
    ${contact}
"""
CYLINDER_EXTENT = """\
if along < cyl_lo[q] or along > cyl_hi[q]:
    ${reset_history}
    continue
"""
#: a turning cylinder's surface moves at omega R (axis x radial unit vector) at the contact point
CYLINDER_SPIN = """\
spin = cyl_omega[q] * cyl_radius[q] / rho
vrx = vix - spin * (ay * rz - az * ry)
vry = viy - spin * (az * rx - ax * rz)
vrz = viz - spin * (ax * ry - ay * rx)
"""
CYLINDER_STILL = "vrx = vix\nvry = viy\nvrz = viz\n"


class Cylinder(WallShape):
    name = "cylinder"
    #: point on the axis (m, 3), unit axis, radius (m), side (+1 inside, -1 outside), angular velocity of the
    #: surface about the axis (rad/s), extent lo/hi along the axis (m, from the point), type
    fields = ("cyl_point", "cyl_axis", "cyl_radius", "cyl_side", "cyl_omega", "cyl_lo", "cyl_hi", "cyl_type")
    features = ("cylinders", "cylinder_spin", "cylinder_extent")

    def parse(self, sim, fields, wall):
        if fields.has("center"):  # along z through (cx, cy)
            cx, cy = fields.vector("center", 2, required=True)
            wall["point"], wall["axis"] = [cx, cy, 0.0], [0.0, 0.0, 1.0]
        else:
            wall["point"] = fields.vector("point", required=True)
            wall["axis"] = axis_or_vector(fields, "axis", required=True)
        wall["radius"] = fields.number("radius", required=True, positive=True)
        wall["side"] = fields.string("side", "inside", choices=("inside", "outside"))
        wall["angular_velocity"] = fields.number("angular_velocity", 0.0)
        extent = fields.vector("extent", 2)
        if extent is not None and extent[1] <= extent[0]:
            raise fields.error("extent", "must be [low, high] along the axis with high > low")
        wall["extent"] = extent
        return None

    def valid(self, w):
        return (numbers(w.get("point"), 3) and numbers(w.get("axis"), 3) and numbers([w.get("radius")], 1)
                and numbers([w.get("angular_velocity")], 1) and w.get("side") in ("inside", "outside"))

    def arrays(self, sim, walls):
        return dict(cyl_point=rows([w["point"] for w in walls]), cyl_axis=rows([w["axis"] for w in walls]),
                    cyl_radius=np.array([w["radius"] for w in walls], dtype=np.float64),
                    cyl_side=np.array([1.0 if w["side"] == "inside" else -1.0 for w in walls], dtype=np.float64),
                    cyl_omega=np.array([w["angular_velocity"] for w in walls], dtype=np.float64),
                    cyl_lo=np.array([(w["extent"] or [-np.inf, np.inf])[0] for w in walls], dtype=np.float64),
                    cyl_hi=np.array([(w["extent"] or [-np.inf, np.inf])[1] for w in walls], dtype=np.float64),
                    cyl_type=np.array([w["type"] - 1 for w in walls], dtype=np.int64))

    def flags(self, walls):
        return dict(cylinders=bool(walls), cylinder_spin=any(w["angular_velocity"] != 0.0 for w in walls),
                    cylinder_extent=any(w["extent"] for w in walls))

    def speed(self, sim, w):
        return abs(w["angular_velocity"]) * w["radius"]

    def reference_points(self, sim, walls):
        return [np.asarray(w["point"], float) for w in walls]

    def gaps(self, sim, walls, x, radius):
        """(R - rho) - r inside, (rho - R) - r outside, rho the distance from its axis (outside its extent: no
        contact)."""
        gaps = []
        for w in walls:
            rel = x - np.asarray(w["point"])
            axis = np.asarray(w["axis"])
            along = rel @ axis
            rho = np.linalg.norm(rel - np.outer(along, axis), axis=1)
            gap = ((w["radius"] - rho) if w["side"] == "inside" else (rho - w["radius"])) - radius
            if w["extent"]:
                gap = np.where((along >= w["extent"][0]) & (along <= w["extent"][1]), gap, np.inf)
            gaps.append(gap)
        return gaps

    def kernel(self, c):
        if not c.cylinders:
            return KernelPart()

        def contacts(contact, reset):
            return render(CYLINDER_CONTACTS, reset_history=reset("wall"), contact=contact("wall"),
                          extent=render(CYLINDER_EXTENT, reset_history=reset("wall")) if c.cylinder_extent else "",
                          surface_velocity=CYLINDER_SPIN if c.cylinder_spin else CYLINDER_STILL)
        return KernelPart(contacts=contacts)
