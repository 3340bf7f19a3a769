"""Regions: named volumes of the scene (``create region``) or inline region objects, and which points they hold.

A region is a plain dict: ``{"shape": "box", "lo": [x, y, z], "hi": [x, y, z]}`` or a z-cylinder
``{"shape": "cylinder", "center": [cx, cy], "radius": R, "z": [z_low, z_high]}`` (m). Wherever a command field
takes a region (``region`` of lattice, random_packing and the insert and outlet modifiers) it takes either the
name of a region created before or such an object. Regions are used two ways: particles created or inserted
lie *entirely* inside (a clearance of their radius, `engine.scene`), while outlets and per-region quantities
select the particles whose *centre* is inside (`contains`). Boundaries belong to the region (closed sets).
"""
from __future__ import annotations

import numpy as np

from .scene import region_bounds, region_contains
from .script import Fields

SHAPES = ("box", "cylinder")


def parse(fields: Fields, extent_fields: Fields | None = None, extent_field: str | None = None) -> dict:
    """The region that fields describe (shape and its geometry fields; the caller finishes fields).

    An extent beyond double precision is reported on extent_field of extent_fields (default: fields itself):
    the command's `region` field for an inline region object; `hi` or `radius` of create region.
    """
    shape = fields.string("shape", required=True, choices=SHAPES)
    out = {"shape": shape}
    if shape == "box":
        out["lo"] = fields.vector("lo", required=True)
        out["hi"] = fields.vector("hi", required=True)
        if any(h <= l for l, h in zip(out["lo"], out["hi"])):
            raise fields.error("hi", "must be greater than 'lo' on every axis")
    else:
        out["center"] = fields.vector("center", 2, required=True)
        out["radius"] = fields.number("radius", required=True, positive=True)
        out["z"] = fields.vector("z", 2, required=True)
        if out["z"][1] <= out["z"][0]:
            raise fields.error("z", "must be [z_low, z_high] with z_high > z_low")
    lo, hi = region_bounds(out)
    if not np.all(np.isfinite(hi - lo)):
        field = extent_field or ("hi" if shape == "box" else "radius")
        raise (extent_fields or fields).error(field, "has an extent beyond double precision")
    return out


def region_of(fields: Fields, regions: dict, name: str = "region", required: bool = True) -> dict | None:
    """The region a command field gives: the name of a region created before, or an inline region object."""
    value = fields.raw(name, required=required)
    if value is None:
        return None
    if isinstance(value, str):
        if value not in regions:
            raise fields.error(name, f"names no region '{value}' (regions: {', '.join(sorted(regions)) or 'none'}; "
                               "create it first or give a region object)")
        return regions[value]
    if not isinstance(value, dict):
        raise fields.error(name, "must be a region name or a region object {\"shape\": \"box\" | \"cylinder\", "
                           "...}")
    sub = Fields(value, fields.where + f", {name}")
    region = parse(sub, fields, name)
    sub.finish()
    return region


def contains(region: dict, points: np.ndarray) -> np.ndarray:
    """Boolean mask of the points (n, 3) whose centre lies in the region (boundary included), vectorised."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return region_contains(region, points, np.zeros(len(points)))


def bounds(region: dict):
    """Axis-aligned bounding box (lo, hi) of a region, m."""
    return region_bounds(region)


def describe(region: dict) -> str:
    """A short text of a region for log lines."""
    if region["shape"] == "box":
        return f"box lo {region['lo']} hi {region['hi']}"
    return f"z-cylinder centre {region['center']} radius {region['radius']:g} z {region['z']}"
