"""The script's commands (after seed 003): create, get, set, fix, unfix, run; one function per command and
per object or property, found through the registries at the end of this module.

Every handler reads its fields through `Fields` (typed, validated, unknown fields refused) and changes the
`Simulation` it is given; `run` is the run loop (`engine.runner`).
"""
from __future__ import annotations

import json
import math
import sys

import numpy as np

from . import clump_commands, guards, memory, modifiers, quantities, regions, runner, superquadric_commands
from . import state as particle_state
from .errors import InputError, RunFailure
from .models import SUBMODELS, choices, coefficients, options
from .restart import read_restart, write_restart
from .scene import lattice_points, random_packing, region_bounds
from .script import Fields
from .walls import SHAPES, set_walls

#: largest material type number (the pair parameter table has MAX^2 rows of its columns)
MAX_MATERIAL_TYPE = 1000


def create_domain(sim, fields: Fields):
    lo = np.array(fields.vector("lo", required=True))
    hi = np.array(fields.vector("hi", required=True))
    if np.any(hi <= lo):
        raise fields.error("hi", "must be greater than 'lo' on every axis")
    if not np.all(np.isfinite(hi - lo)):
        raise fields.error("hi", "gives a domain extent hi - lo beyond double precision")
    periodic = fields.raw("periodic", [False, False, False])
    if not (isinstance(periodic, list) and len(periodic) == 3 and all(isinstance(p, bool) for p in periodic)):
        raise fields.error("periodic", "must be a list of 3 booleans")
    sim.lo, sim.hi = lo, hi
    sim.periodic = np.array(periodic, dtype=np.bool_)


def material_type(sim, fields: Fields, name="type") -> int:
    t = fields.integer(name, required=True, minimum=1)
    if t not in sim.materials:
        raise fields.error(name, f"names unknown material type {t} (create a material with this type first)")
    return t


#: Pa, the largest Young's modulus accepted (a thousand times diamond's)
MAX_YOUNGS_MODULUS = 1e15


def create_material(sim, fields: Fields):
    # the pair parameter table holds (largest type)^2 entries: type numbers are labels, not a count
    t = fields.integer("type", required=True, minimum=1, maximum=MAX_MATERIAL_TYPE)
    # at most MAX_YOUNGS_MODULUS: no material comes near it (diamond 1.2e12 Pa), and the Hertz time's Y*^2 and
    # the contact forces of larger moduli leave double precision (Y = 1e300 overflows to inf)
    y = fields.number("youngs_modulus", required=True, positive=True, maximum=MAX_YOUNGS_MODULUS)
    nu = fields.number("poisson_ratio", required=True, minimum=0.0, maximum=0.5)
    rho = fields.number("density", required=True, positive=True)
    if y < 5e6:
        sim.log.warning(f"material type {t}: Young's modulus {y:g} Pa < 5e6 Pa (LIGGGHTS calls such "
                        "particles soft and refuses them)")
    sim.materials[t] = (y, nu, rho)


def create_interaction(sim, fields: Fields):
    """The coefficients of a pair of material types: those every submodel declares (models.SUBMODELS)."""
    types = fields.raw("types", required=True)
    if not (isinstance(types, list) and len(types) == 2 and all(isinstance(t, int) and not isinstance(t, bool)
                                                                for t in types)):
        raise fields.error("types", f"must be a list of two material types, got {json.dumps(types)}")
    for t in types:
        if t not in sim.materials:
            raise fields.error("types", f"names unknown material type {t}")
    values = {}
    for coefficient in coefficients():
        value = fields.number(coefficient.name, coefficient.default, required=coefficient.default is None,
                              minimum=coefficient.minimum)
        problem = coefficient.check(value) if coefficient.check else ""
        if problem:
            raise fields.error(coefficient.name, problem)
        values[coefficient.name] = value
    sim.interactions[(min(types), max(types))] = values


def create_contact_model(sim, fields: Fields):
    """A law per kind of submodel (models.SUBMODELS) and their options."""
    model = {kind: fields.string(kind, None if sub.required else sub.default, required=sub.required,
                                 choices=choices(kind)) for kind, sub in SUBMODELS.items()}
    model.update({name: fields.boolean(name, option.default) for name, option in options().items()})
    velocity = fields.number("characteristic_velocity", None, positive=True)
    if model["normal"] == "hooke" and velocity is None:
        raise fields.error("characteristic_velocity", "is missing (the Hooke model needs it, m/s)")
    if velocity is not None and velocity < 0.01:
        raise fields.error("characteristic_velocity", "must be >= 0.01 m/s (LIGGGHTS' limit)")
    model["characteristic_velocity"] = velocity or 0.0
    sim.model = model


def create_wall(sim, fields: Fields):
    """A wall of one of the shapes of engine.walls (the fields are in engine/README.md)."""
    name = fields.string("name", required=True)
    if any(w["name"] == name for w in sim.walls):
        raise fields.error("name", f"'{name}' is already a wall")
    shape = fields.string("shape", required=True, choices=tuple(SHAPES))
    wall = dict(name=name, shape=shape, type=material_type(sim, fields))
    triangles = SHAPES[shape].parse(sim, fields, wall)
    set_walls(sim, sim.walls + [wall], triangles={name: triangles} if triangles is not None else {})
    sim.state = particle_state.fit_wall_history(sim.state, 0, 0)


def particle_bytes(sim) -> int:
    """Bytes one particle holds in the state arrays (and its wall history row and neighbor list start)."""
    # wall history: up to 6 doubles per wall; one neighbor list start per particle
    return particle_state.bytes_per_particle(len(sim.walls), 6) + sim.nbr.start.itemsize


def check_memory(sim, fields: Fields, field: str, new: int, what: str, **temporaries):
    """Refuse a create that cannot fit, before anything is allocated: more bytes than the machine has
    available (memory.available_bytes), or more particles than int32 neighbor indices address."""
    need = memory.creation_bytes(new, sim.n, particle_bytes(sim), **temporaries)
    available = memory.available_bytes()
    if available is not None and need > available:
        raise fields.error(field, f"{what} {new:.3g} particles, which need about {memory.human(need)} of "
                           f"memory ({particle_bytes(sim)} B per particle in the state, plus the "
                           f"temporaries of the create); {memory.human(available)} are available")
    if sim.n + new > memory.MAX_PARTICLES:
        raise fields.error(field, f"{what} {new:.3g} particles; the engine holds at most "
                           f"{memory.MAX_PARTICLES} (32-bit neighbor indices)")


def add_particles(sim, t: int, positions, radii, velocity, omega, fields: Fields | None = None):
    n = len(positions)
    if n == 0:
        return
    y, nu, rho = sim.materials[t]
    mass = rho * 4.0 / 3.0 * math.pi * radii ** 3
    if fields is not None:
        check_particle_values(sim, fields, t, radii, mass, np.asarray(velocity, float),
                                    np.asarray(omega, float))
    walls, history = sim.state.wall_hist.shape[1:]
    sim.state = particle_state.append(
        sim.state, x=positions, v=np.tile(velocity, (n, 1)), omega=np.tile(omega, (n, 1)), radius=radii,
        mass=mass, inv_mass=1.0 / mass, inv_inertia=1.0 / (0.4 * mass * radii ** 2),
        ptype=np.full(n, t - 1, dtype=np.int64), pid=np.arange(sim.next_id, sim.next_id + n, dtype=np.int64),
        x_build=positions, wall_hist=np.zeros((n, walls, history)))
    sim.next_id += n
    sim.dirty = True


def check_particle_values(sim, fields: Fields, t: int, radii, mass, velocity, omega):
    """Values the integrator divides by or squares must be finite doubles: mass, 1/m, 1/I (I = 0.4 m r^2),
    the kinetic energies 0.5 m v^2 and 0.5 I w^2 (radius 1e-200 m, density 1e-300 kg/m^3 or a speed of
    1e200 m/s each overflow one of them and would poison the run with inf and nan)."""
    radius_field = "radius" if fields.has("radius") or not fields.has("radius_min") else "radius_min"
    inertia = 0.4 * mass * radii ** 2
    with np.errstate(all="ignore"):
        bad_mass = ~(np.isfinite(mass) & (mass > 0) & np.isfinite(1.0 / mass) & (inertia > 0)
                     & np.isfinite(1.0 / inertia))
        if bad_mass.any():
            k = int(np.nonzero(bad_mass)[0][0])
            raise fields.error(radius_field, f"{radii[k]:g} m with material type {t} (density "
                               f"{sim.materials[t][2]:g} kg/m^3) gives a mass {mass[k]:.3g} kg whose "
                               "inverse or inverse moment of inertia is not a finite double")
        for name, inert, value, energy in (("velocity", mass, velocity, "kinetic"),
                                           ("omega", inertia, omega, "rotational")):
            e = 0.5 * inert * float(np.dot(value, value))
            if not np.all(np.isfinite(e)):
                raise fields.error(name, f"{value.tolist()} gives a {energy} energy that is not a finite "
                                   "double")


def radii_of(fields: Fields, count: int, rng=None) -> np.ndarray:
    if fields.has("radius"):
        return np.full(count, fields.number("radius", required=True, positive=True))
    rmin = fields.number("radius_min", required=True, positive=True)
    rmax = fields.number("radius_max", required=True, positive=True)
    if rmax < rmin:
        raise fields.error("radius_max", "must be >= radius_min")
    return rmin + (rmax - rmin) * rng.random(count)


def region_of(sim, fields: Fields) -> dict:
    """The `region` field of a create: a region name or an inline region object (engine.regions)."""
    return regions.region_of(fields, sim.regions)


def create_region(sim, fields: Fields):
    """A named region (box or z-cylinder) that later fields name instead of an inline region object."""
    name = fields.string("name", required=True)
    if name in sim.regions:
        raise fields.error("name", f"'{name}' is already a region")
    sim.regions[name] = regions.parse(fields)


def create_particle(sim, fields: Fields):
    t = material_type(sim, fields)
    r = fields.number("radius", required=True, positive=True)
    position = fields.vector("position", required=True)
    add_particles(sim, t, np.array([position]), np.array([r]), fields.vector("velocity", default=[0, 0, 0]),
                        fields.vector("omega", default=[0, 0, 0]), fields)


def create_lattice(sim, fields: Fields):
    t = material_type(sim, fields)
    r = fields.number("radius", required=True, positive=True)
    spacing = fields.number("spacing", required=True, positive=True)
    if spacing < 2 * r:
        sim.log.warning(f"{fields.where}: lattice spacing {spacing:g} m < 2 radius: neighbors start "
                        f"with an overlap of {2 * r - spacing:g} m")
    region = region_of(sim, fields)
    sites = memory.lattice_sites(*region_bounds(region), spacing)
    check_memory(sim, fields, "spacing", sites, "gives a lattice of up to", grid_sites=sites)
    points = lattice_points(region, spacing, r)
    add_particles(sim, t, points, np.full(len(points), r), fields.vector("velocity", default=[0, 0, 0]),
                        fields.vector("omega", default=[0, 0, 0]), fields)
    sim.log.info(f"created {len(points)} particles on a lattice")


def create_random_packing(sim, fields: Fields):
    t = material_type(sim, fields)
    count = fields.integer("count", required=True, minimum=1)
    seed = fields.integer("seed", required=True, minimum=0)
    attempts = fields.integer("max_attempts", 200, minimum=1)
    region = region_of(sim, fields)
    check_memory(sim, fields, "count", count, "asks for", attempts=attempts)
    rng = np.random.Generator(np.random.PCG64([seed, 1]))
    radii = radii_of(fields, count, rng)
    points = random_packing(region, radii, seed, sim.state.x, sim.state.radius, attempts)
    if len(points) < count:
        raise RunFailure(f"{fields.where}: placed only {len(points)} of {count} particles without overlap "
                         f"in {attempts} attempts each; enlarge the region or lower 'count'")
    add_particles(sim, t, points, radii, fields.vector("velocity", default=[0, 0, 0]),
                        fields.vector("omega", default=[0, 0, 0]), fields)
    sim.log.info(f"created {len(points)} particles by random packing (seed {seed})")


def create_modifier(sim, fields: Fields):
    mod = modifiers.create(fields, sim)
    restored = sim.modifier_state.get(mod.name)
    if restored is not None and restored.get("kind") == mod.kind:
        mod.restore(restored)  # counters of a restart file (insert, outlet): the continuation goes on counting
    sim.modifiers[mod.name] = mod


def create_restart(sim, fields: Fields):
    write_restart(sim, fields.output_path("file", required=True))


def fix(sim, fields: Fields):
    name = fields.string("name", required=True)
    if name not in sim.modifiers:
        raise fields.error("name", f"names no modifier '{name}' (create it first)")
    if name not in sim.active:
        sim.active.append(name)


def unfix(sim, fields: Fields):
    name = fields.string("name", required=True)
    if name not in sim.active:
        raise fields.error("name", f"names no fixed modifier '{name}'")
    sim.active.remove(name)


def set_timestep(sim, fields: Fields):
    value = fields.number("value", positive=True)
    fraction = fields.number("fraction_of_critical", positive=True)
    if (value is None) == (fraction is None):
        raise fields.error("value", "give either 'value' (s) or 'fraction_of_critical' (of min(t_R, t_H))")
    if fraction is not None:
        # a time step as a fraction of the critical one, as sweeps over accuracy ask for it
        t_c = min(guards.critical_timestep(sim))
        if not math.isfinite(t_c):
            raise fields.error("fraction_of_critical", "needs particles to estimate the critical time step "
                               "(create them first)")
        value = fraction * t_c
        sim.log.info(f"time step {value!r} s = {fraction:g} x critical time step {t_c:.6g} s")
    if value < sys.float_info.min:
        # a subnormal double keeps fewer digits than the time it is added to, down to one bit at 5e-324
        raise fields.error("fraction_of_critical" if fraction is not None else "value",
                           f"gives a time step of {value:g} s, below the smallest normal double "
                           f"{sys.float_info.min:g}: the simulated time cannot resolve it")
    sim.dt = value


def set_skin(sim, fields: Fields):
    sim.skin = fields.number("value", required=True, positive=True)


def set_thermo(sim, fields: Fields):
    every = fields.integer("every", 0, minimum=0)
    columns = fields.strings("columns", [])
    for q in columns:
        if not quantities.known(q):
            raise fields.error("columns", f"names unknown quantity '{q}'")
    sim.output.set_thermo(every, columns, fields.output_path("file", sim.output.thermo_file))


def set_timestep_check(sim, fields: Fields):
    sim.timestep_fraction = fields.number("fraction", sim.timestep_fraction, positive=True)
    sim.timestep_strict = fields.boolean("strict", sim.timestep_strict)
    sim.timestep_every = fields.integer("every", sim.timestep_every, minimum=0)


def set_restart(sim, fields: Fields):
    read_restart(sim, fields.string("file", required=True), fields)


def set_velocity(sim, fields: Fields):
    value = fields.vector("value", required=True)
    t = fields.integer("type", None, minimum=1)
    mask = np.ones(sim.n, dtype=bool) if t is None else sim.state.ptype == t - 1
    if mask.any():
        heaviest = float(sim.state.mass[mask].max())
        with np.errstate(all="ignore"):
            energy = 0.5 * heaviest * float(np.dot(value, value))
        if not math.isfinite(energy):
            raise fields.error("value", f"{value} gives a kinetic energy that is not a finite double")
    sim.state.v[mask] = value
    sim.dirty = True


def set_blowup(sim, fields: Fields):
    """The blow-up limits for a hard case (engine/blowup.py): ``max_overlap`` (of the smaller radius),
    ``timestep_factor`` (times the critical time step), ``enabled`` (false: no limit at all)."""
    overlap = fields.number("max_overlap", positive=True)
    factor = fields.number("timestep_factor", positive=True)
    sim.blowup_overlap = sim.blowup_overlap if overlap is None else overlap
    sim.blowup_timestep = sim.blowup_timestep if factor is None else factor
    if not fields.boolean("enabled", True):
        sim.blowup_overlap = sim.blowup_timestep = math.inf


def get(sim, fields: Fields):
    prop = fields.string("property", required=True)
    if prop == "critical_timestep":
        t_r, t_h = guards.critical_timestep(sim)
        sim.log.info(f"critical_timestep: rayleigh_time = {t_r!r} s, hertz_time = {t_h!r} s")
    elif quantities.known(prop):
        problem = quantities.unknown_reference(sim, prop)
        if problem:
            raise fields.error("property", f"quantity '{prop}' {problem}")
        sim.log.info(f"{prop} = {quantities.evaluate(sim, prop)!r}")
    else:
        raise fields.error("property", f"names unknown property '{prop}'")


def create(sim, fields: Fields):
    kind = fields.string("object", required=True, choices=tuple(CREATE))
    CREATE[kind](sim, fields)


def set_property(sim, fields: Fields):
    prop = fields.string("property", required=True, choices=tuple(SET))
    SET[prop](sim, fields)


CREATE = {"domain": create_domain, "material": create_material, "interaction": create_interaction,
          "contact_model": create_contact_model, "wall": create_wall, "particle": create_particle,
          "lattice": create_lattice, "random_packing": create_random_packing, "modifier": create_modifier,
          "restart": create_restart, "region": create_region}
CREATE.update(clump_commands.CREATE)
CREATE.update(superquadric_commands.CREATE)
SET = {"timestep": set_timestep, "skin": set_skin, "thermo": set_thermo, "timestep_check": set_timestep_check,
       "restart": set_restart, "velocity": set_velocity, "blowup": set_blowup}
COMMANDS = {"create": create, "get": get, "set": set_property, "fix": fix, "unfix": unfix, "run": runner.run}


def execute(sim, cmd: dict, index: int, script: str):
    """Run one command of a script (index from 1) on sim; the log echoes it first."""
    name = cmd.get("command")
    label = name
    if name == "create" and isinstance(cmd.get("object"), str):
        label = f"create {cmd['object']}"
    elif name in ("set", "get") and isinstance(cmd.get("property"), str):
        label = f"{name} {cmd['property']}"
    fields = Fields(cmd, f"{script}: command {index} ({label})")
    sim.log.info(f"command {index} ({label}): {json.dumps(cmd)}")
    handler = COMMANDS.get(name) if isinstance(name, str) else None
    if handler is None:
        raise InputError(f"{script}: command {index}: unknown command {json.dumps(name)} "
                         "(known: create, get, set, fix, unfix, run)")
    handler(sim, fields)
    fields.finish()
