"""The script's clump objects: `create clump_template`, `create clump`, `create clump_packing` (engine/clumps.py).

Fields are in engine/README.md (*Clumps*). A template's `spheres` are [x, y, z, r] in its own frame (m); a
clump's `position` is its centre of mass, its `orientation` turns the template frame into space
(`{"axis": [...], "angle": degrees}` or `{"quaternion": [w, x, y, z]}`).
"""
from __future__ import annotations

import math

import numpy as np

from . import clumps
from .errors import RunFailure
from .regions import region_of
from .scene import random_packing
from .script import Fields


def _material(sim, fields: Fields) -> int:
    t = fields.integer("type", required=True, minimum=1)
    if t not in sim.materials:
        raise fields.error("type", f"names unknown material type {t} (create a material with this type first)")
    return t


def create_template(sim, fields: Fields):
    name = fields.string("name", required=True)
    if name in sim.clump_templates:
        raise fields.error("name", f"'{name}' is already a clump template")
    t = _material(sim, fields)
    spheres = fields.raw("spheres", required=True)
    if not (isinstance(spheres, list) and spheres and all(
            isinstance(s, list) and len(s) == 4 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                        and math.isfinite(v) for v in s) for s in spheres)):
        raise fields.error("spheres", "must be a non-empty list of [x, y, z, radius] (m)")
    data = np.array(spheres, dtype=float)
    if np.any(data[:, 3] <= 0):
        raise fields.error("spheres", "every radius must be > 0")
    samples = fields.integer("samples", clumps.DEFAULT_SAMPLES, minimum=1024)
    seed = fields.integer("seed", 0, minimum=0)
    template = clumps.Template(name, t, data[:, :3], data[:, 3], sim.materials[t][2], samples, seed)
    if not (template.mass > 0 and np.all(template.moments > 0) and math.isfinite(1.0 / template.moments.min())):
        raise fields.error("spheres", f"give a mass {template.mass:.3g} kg or moments of inertia "
                           f"{template.moments.tolist()} whose inverse is not finite")
    sim.clump_templates[name] = template
    how = "exact (no overlaps)" if template.exact else (f"{samples} quasi-random points, relative standard error "
                                                        f"below {template.error:.2g}")
    sim.log.info(f"clump template '{name}': {len(template.radii)} spheres, mass {template.mass!r} kg, volume "
                 f"{template.volume!r} m^3, principal moments {template.moments.tolist()} kg m^2 ({how})")


def _template(sim, fields: Fields) -> clumps.Template:
    name = fields.string("template", required=True)
    if name not in sim.clump_templates:
        raise fields.error("template", f"names no clump template '{name}' (templates: "
                           f"{', '.join(sorted(sim.clump_templates)) or 'none'})")
    return sim.clump_templates[name]


def orientation_of(fields: Fields, name: str = "orientation") -> np.ndarray:
    """Unit quaternion of {"axis": [...], "angle": degrees} or {"quaternion": [w, x, y, z]}; default none."""
    value = fields.mapping(name, {})
    if not value:
        return np.array([1.0, 0.0, 0.0, 0.0])
    sub = Fields(value, f"{fields.where}: field '{name}'")
    if sub.has("quaternion"):
        q = np.array(sub.vector("quaternion", length=4, required=True))
        norm = float(np.linalg.norm(q))
        if not norm > 0:
            raise fields.error(name, "quaternion must not be zero")
        sub.finish()
        return q / norm
    axis = np.array(sub.vector("axis", required=True))
    if not np.linalg.norm(axis) > 0:
        raise fields.error(name, "axis must not be zero")
    angle = sub.number("angle", required=True)
    sub.finish()
    return clumps.axis_angle_quaternion(axis, angle)


def create_clump(sim, fields: Fields):
    template = _template(sim, fields)
    position = np.array(fields.vector("position", required=True))
    q = orientation_of(fields)
    clumps.add_bodies(sim, template, position[None, :], q[None, :], fields.vector("velocity", default=[0, 0, 0]),
                      fields.vector("omega", default=[0, 0, 0]))


def create_clump_packing(sim, fields: Fields):
    """count clumps of a template at random positions (no overlap of their bounding spheres with each other
    or with particles there) and random orientations (uniform; Shoemake), from seed."""
    template = _template(sim, fields)
    count = fields.integer("count", required=True, minimum=1)
    seed = fields.integer("seed", required=True, minimum=0)
    attempts = fields.integer("max_attempts", 200, minimum=1)
    region = region_of(fields, sim.regions)
    radii = np.full(count, template.bounding_radius)
    points = random_packing(region, radii, seed, sim.state.x, sim.state.radius, attempts)
    if len(points) < count:
        raise RunFailure(f"{fields.where}: placed only {len(points)} of {count} clumps without overlap in "
                         f"{attempts} attempts each; enlarge the region or lower 'count'")
    q = clumps.random_quaternions(np.random.Generator(np.random.PCG64([seed, 3])), count)
    clumps.add_bodies(sim, template, points, q, fields.vector("velocity", default=[0, 0, 0]),
                      fields.vector("omega", default=[0, 0, 0]))
    sim.log.info(f"created {count} clumps of template '{template.name}' by random packing (seed {seed})")


CREATE = {"clump_template": create_template, "clump": create_clump, "clump_packing": create_clump_packing}
