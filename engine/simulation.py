"""The simulation: scene state, the six commands, and the run loop around the compiled kernel.

Between two output steps the whole step loop runs inside compiled code (`engine.kernels`); Python only
decides where the next output is, writes it, and checks the guards (critical time step, non-finite values,
large overlaps, particles lost from a fixed box).
"""
from __future__ import annotations

import json
import math
import re
import time
from collections import namedtuple
from pathlib import Path

import numpy as np

from . import memory
from .contact_laws import effective_youngs_modulus
from .errors import InputError, RunFailure, output_failure
from .kernels import (COHESION_MODELS, NORMAL_MODELS, ROLLING_MODELS, TANGENTIAL_MODELS, Combination, build_kernel,
                      parameter_table)
from .log import Log  # noqa: F401 - part of this module's interface (tests build a Simulation on a Log)
from . import state as particle_state
from .neighbor import NeighborList, empty_list, lost_record, overlap_statistics
from .scene import lattice_points, random_packing, region_bounds
from .script import Fields
from .walls import overlap_ratios, wall_set
from .writers import CsvSeries, write_vtp

#: scalars and small arrays every step reads: dt (s), characteristic velocity (m/s, Hooke), gravity (m/s^2, 3),
#: domain lo, hi (m, 3), periodic (3 booleans), skin (m)
Constants = namedtuple("Constants", ["dt", "characteristic_velocity", "gravity", "lo", "hi", "periodic", "skin"])

AXES = {"x": 0, "y": 1, "z": 2}
GLOBAL_QUANTITIES = ("step", "time", "atoms", "ke", "rke", "pe", "energy", "momentum_x", "momentum_y",
                     "momentum_z", "com_x", "com_y", "com_z", "max_speed", "contacts", "max_overlap")
PARTICLE_QUANTITIES = ("x", "y", "z", "vx", "vy", "vz", "fx", "fy", "fz", "omegax", "omegay", "omegaz")
_PARTICLE_QUANTITY = re.compile(r"^(%s)\[(\d+)\]$" % "|".join(PARTICLE_QUANTITIES))
#: force the particles exert on a wall (N) at the last step, e.g. wall_fz[floor]
_WALL_QUANTITY = re.compile(r"^wall_f([xyz])\[([^\]]+)\]$")
THERMO_FIRST = ["step", "time", "atoms", "ke", "rke"]
RESTART_FORMAT = 2
#: overlaps above this fraction of the smaller radius are reported (issue 2)
OVERLAP_WARN_RATIO = 0.1
#: the critical time step is re-checked with the current velocities every this many steps (LIGGGHTS' fix
#: check/timestep/gran re-checks every N steps too: the Hertz time falls as particles speed up)
TIMESTEP_CHECK_EVERY = 1000
#: largest material type number (the pair parameter table has MAX^2 rows of 7 doubles: 56 MB)
MAX_MATERIAL_TYPE = 1000
#: restart file arrays of the neighbor list (the particle fields are stored under their names, state.py)
NEIGHBOR_ARRAYS = {"nbr_start": "start", "nbr_j": "j", "pair_hist": "hist"}


def check_quantity(name: str) -> bool:
    return (name in GLOBAL_QUANTITIES or _PARTICLE_QUANTITY.match(name) is not None
            or _WALL_QUANTITY.match(name) is not None)


class Simulation:
    """One scene. Types are numbered from 1 in scripts and from 0 inside arrays (``ptype = type - 1``)."""

    def __init__(self, log: Log):
        self.log = log
        self.lo = self.hi = None
        self.periodic = np.zeros(3, dtype=np.bool_)
        self.skin = 0.001  # m, the LIGGGHTS SI default
        self.dt = None
        self.step = 0
        self.time = 0.0
        self.materials: dict[int, tuple] = {}
        self.interactions: dict[tuple, dict] = {}
        self.model: dict | None = None
        self.walls: list[dict] = []
        self.plane_pos = np.zeros(0)
        self.wall_force = np.zeros((0, 3))  # N, on each wall (planes, then cylinders) at the last step
        self.state = particle_state.empty()
        self.nbr = empty_list()
        self.modifiers: dict[str, dict] = {}
        self.active: list[str] = []
        self.timestep_fraction = 0.2
        self.timestep_strict = False
        self.timestep_every = TIMESTEP_CHECK_EVERY
        self.thermo_every = 0
        self.thermo_columns = list(THERMO_FIRST)
        self.thermo_file = "thermo.csv"
        self.thermo: CsvSeries | None = None
        self.next_id = 1
        # forces must be evaluated before the next step: only changes of the particle set or their velocities
        # do this; a model change (walls, gravity, materials) acts from the next step's force evaluation, so
        # a restart continues bitwise whatever the continuation script declares
        self.dirty = True
        self.lost_total = 0
        self.timing = dict(pair=0.0, neigh=0.0, comm=0.0, modify=0.0, output=0.0, other=0.0, total=0.0,
                           cpu=0.0, compile=0.0, steps=0, particles=0, particle_steps=0)

    # ------------------------------------------------------------------ commands
    def execute(self, cmd: dict, index: int, script: str):
        name = cmd.get("command")
        label = name
        if name == "create" and isinstance(cmd.get("object"), str):
            label = f"create {cmd['object']}"
        elif name in ("set", "get") and isinstance(cmd.get("property"), str):
            label = f"{name} {cmd['property']}"
        fields = Fields(cmd, f"{script}: command {index} ({label})")
        self.log.info(f"command {index} ({label}): {json.dumps(cmd)}")
        handler = getattr(self, f"cmd_{name}", None) if name in ("create", "get", "set", "fix", "unfix", "run") \
            else None
        if handler is None:
            raise InputError(f"{script}: command {index}: unknown command {json.dumps(name)} "
                             "(known: create, get, set, fix, unfix, run)")
        handler(fields)
        fields.finish()

    def cmd_create(self, fields: Fields):
        kind = fields.string("object", required=True,
                             choices=("domain", "material", "interaction", "contact_model", "wall", "particle",
                                      "lattice", "random_packing", "modifier", "restart"))
        getattr(self, f"create_{kind}")(fields)

    def create_domain(self, fields: Fields):
        lo = np.array(fields.vector("lo", required=True))
        hi = np.array(fields.vector("hi", required=True))
        if np.any(hi <= lo):
            raise fields.error("hi", "must be greater than 'lo' on every axis")
        if not np.all(np.isfinite(hi - lo)):
            raise fields.error("hi", "gives a domain extent hi - lo beyond double precision")
        periodic = fields.raw("periodic", [False, False, False])
        if not (isinstance(periodic, list) and len(periodic) == 3 and all(isinstance(p, bool) for p in periodic)):
            raise fields.error("periodic", "must be a list of 3 booleans")
        self.lo, self.hi = lo, hi
        self.periodic = np.array(periodic, dtype=np.bool_)

    def _type(self, fields: Fields, name="type") -> int:
        t = fields.integer(name, required=True, minimum=1)
        if t not in self.materials:
            raise fields.error(name, f"names unknown material type {t} (create a material with this type first)")
        return t

    def create_material(self, fields: Fields):
        # the pair parameter table holds (largest type)^2 entries: type numbers are labels, not a count
        t = fields.integer("type", required=True, minimum=1, maximum=MAX_MATERIAL_TYPE)
        y = fields.number("youngs_modulus", required=True, positive=True)
        nu = fields.number("poisson_ratio", required=True, minimum=0.0, maximum=0.5)
        rho = fields.number("density", required=True, positive=True)
        if y < 5e6:
            self.log.warning(f"material type {t}: Young's modulus {y:g} Pa < 5e6 Pa (LIGGGHTS calls such "
                             "particles soft and refuses them)")
        self.materials[t] = (y, nu, rho)

    def create_interaction(self, fields: Fields):
        types = fields.raw("types", required=True)
        if not (isinstance(types, list) and len(types) == 2 and all(isinstance(t, int) and not isinstance(t, bool)
                                                                    for t in types)):
            raise fields.error("types", f"must be a list of two material types, got {json.dumps(types)}")
        for t in types:
            if t not in self.materials:
                raise fields.error("types", f"names unknown material type {t}")
        e = fields.number("restitution", required=True)
        if not 0.0 < e <= 1.0:
            raise fields.error("restitution", f"must be in (0, 1], got {e:g}")
        self.interactions[(min(types), max(types))] = dict(
            restitution=e,
            friction=fields.number("friction", 0.0, minimum=0.0),
            rolling_friction=fields.number("rolling_friction", 0.0, minimum=0.0),
            cohesion_energy_density=fields.number("cohesion_energy_density", 0.0, minimum=0.0))

    def create_contact_model(self, fields: Fields):
        model = dict(normal=fields.string("normal", required=True, choices=NORMAL_MODELS),
                     tangential=fields.string("tangential", "none", choices=TANGENTIAL_MODELS),
                     cohesion=fields.string("cohesion", "none", choices=COHESION_MODELS),
                     rolling=fields.string("rolling", "none", choices=ROLLING_MODELS),
                     limit_force=fields.boolean("limit_force", False),
                     tangential_damping=fields.boolean("tangential_damping", True))
        velocity = fields.number("characteristic_velocity", None, positive=True)
        if model["normal"] == "hooke" and velocity is None:
            raise fields.error("characteristic_velocity", "is missing (the Hooke model needs it, m/s)")
        if velocity is not None and velocity < 0.01:
            raise fields.error("characteristic_velocity", "must be >= 0.01 m/s (LIGGGHTS' limit)")
        model["characteristic_velocity"] = velocity or 0.0
        self.model = model

    def create_wall(self, fields: Fields):
        name = fields.string("name", required=True)
        if any(w["name"] == name for w in self.walls):
            raise fields.error("name", f"'{name}' is already a wall")
        shape = fields.string("shape", required=True, choices=("plane", "cylinder"))
        wall = dict(name=name, shape=shape, type=self._type(fields))
        if shape == "plane":
            wall["axis"] = AXES[fields.string("axis", required=True, choices=tuple(AXES))]
            wall["position"] = fields.number("position", required=True)
            wall["velocity"] = fields.vector("velocity", default=[0.0, 0.0, 0.0])
        else:
            wall["center"] = fields.vector("center", 2, required=True)
            wall["radius"] = fields.number("radius", required=True, positive=True)
            wall["side"] = fields.string("side", "inside", choices=("inside", "outside"))
        self._set_walls(self.walls + [wall], fresh_history=True)

    def _set_walls(self, walls, fresh_history):
        old_positions = {w["name"]: p for w, p in zip([w for w in self.walls if w["shape"] == "plane"],
                                                       self.plane_pos)}
        planes = [w for w in walls if w["shape"] == "plane"]
        cylinders = [w for w in walls if w["shape"] == "cylinder"]
        self.walls = planes + cylinders  # wall history columns: planes first, then cylinders
        self.plane_pos = np.array([old_positions.get(w["name"], w["position"]) for w in planes], dtype=np.float64)
        if fresh_history:
            self.state = particle_state.fit_wall_history(self.state, 0, 0)

    def _particle_bytes(self) -> int:
        """Bytes one particle holds in the state arrays (and its wall history row and neighbor list start)."""
        # wall history: up to 6 doubles per wall; one neighbor list start per particle
        return particle_state.bytes_per_particle(len(self.walls), 6) + self.nbr.start.itemsize

    def _check_memory(self, fields: Fields, field: str, new: int, what: str, **temporaries):
        """Refuse a create that cannot fit, before anything is allocated: more bytes than the machine has
        available (memory.available_bytes), or more particles than int32 neighbor indices address."""
        need = memory.creation_bytes(new, self.n, self._particle_bytes(), **temporaries)
        available = memory.available_bytes()
        if available is not None and need > available:
            raise fields.error(field, f"{what} {new:.3g} particles, which need about {memory.human(need)} of "
                               f"memory ({self._particle_bytes()} B per particle in the state, plus the "
                               f"temporaries of the create); {memory.human(available)} are available")
        if self.n + new > memory.MAX_PARTICLES:
            raise fields.error(field, f"{what} {new:.3g} particles; the engine holds at most "
                               f"{memory.MAX_PARTICLES} (32-bit neighbor indices)")

    def _add_particles(self, t: int, positions, radii, velocity, omega, fields: Fields | None = None):
        n = len(positions)
        if n == 0:
            return
        y, nu, rho = self.materials[t]
        mass = rho * 4.0 / 3.0 * math.pi * radii ** 3
        if fields is not None:
            self._check_particle_values(fields, t, radii, mass, np.asarray(velocity, float),
                                        np.asarray(omega, float))
        walls, history = self.state.wall_hist.shape[1:]
        self.state = particle_state.append(
            self.state, x=positions, v=np.tile(velocity, (n, 1)), omega=np.tile(omega, (n, 1)), radius=radii,
            mass=mass, inv_mass=1.0 / mass, inv_inertia=1.0 / (0.4 * mass * radii ** 2),
            ptype=np.full(n, t - 1, dtype=np.int64), pid=np.arange(self.next_id, self.next_id + n, dtype=np.int64),
            x_build=positions, wall_hist=np.zeros((n, walls, history)))
        self.next_id += n
        self.dirty = True

    def _check_particle_values(self, fields: Fields, t: int, radii, mass, velocity, omega):
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
                                   f"{self.materials[t][2]:g} kg/m^3) gives a mass {mass[k]:.3g} kg whose "
                                   "inverse or inverse moment of inertia is not a finite double")
            for name, inert, value, energy in (("velocity", mass, velocity, "kinetic"),
                                               ("omega", inertia, omega, "rotational")):
                e = 0.5 * inert * float(np.dot(value, value))
                if not np.all(np.isfinite(e)):
                    raise fields.error(name, f"{value.tolist()} gives a {energy} energy that is not a finite "
                                       "double")

    def _radii(self, fields: Fields, count: int, rng=None) -> np.ndarray:
        if fields.has("radius"):
            return np.full(count, fields.number("radius", required=True, positive=True))
        rmin = fields.number("radius_min", required=True, positive=True)
        rmax = fields.number("radius_max", required=True, positive=True)
        if rmax < rmin:
            raise fields.error("radius_max", "must be >= radius_min")
        return rmin + (rmax - rmin) * rng.random(count)

    def _region(self, fields: Fields) -> dict:
        region = fields.mapping("region", required=True)
        sub = Fields(region, fields.where + ", region")
        shape = sub.string("shape", required=True, choices=("box", "cylinder"))
        out = {"shape": shape}
        if shape == "box":
            out["lo"] = sub.vector("lo", required=True)
            out["hi"] = sub.vector("hi", required=True)
            if any(h <= l for l, h in zip(out["lo"], out["hi"])):
                raise sub.error("hi", "must be greater than 'lo' on every axis")
        else:
            out["center"] = sub.vector("center", 2, required=True)
            out["radius"] = sub.number("radius", required=True, positive=True)
            out["z"] = sub.vector("z", 2, required=True)
            if out["z"][1] <= out["z"][0]:
                raise sub.error("z", "must be [z_low, z_high] with z_high > z_low")
        sub.finish()
        lo, hi = region_bounds(out)
        if not np.all(np.isfinite(hi - lo)):
            raise fields.error("region", "has an extent beyond double precision")
        return out

    def create_particle(self, fields: Fields):
        t = self._type(fields)
        r = fields.number("radius", required=True, positive=True)
        position = fields.vector("position", required=True)
        self._add_particles(t, np.array([position]), np.array([r]), fields.vector("velocity", default=[0, 0, 0]),
                            fields.vector("omega", default=[0, 0, 0]), fields)

    def create_lattice(self, fields: Fields):
        t = self._type(fields)
        r = fields.number("radius", required=True, positive=True)
        spacing = fields.number("spacing", required=True, positive=True)
        if spacing < 2 * r:
            self.log.warning(f"{fields.where}: lattice spacing {spacing:g} m < 2 radius: neighbors start "
                             f"with an overlap of {2 * r - spacing:g} m")
        region = self._region(fields)
        sites = memory.lattice_sites(*region_bounds(region), spacing)
        self._check_memory(fields, "spacing", sites, "gives a lattice of up to", grid_sites=sites)
        points = lattice_points(region, spacing, r)
        self._add_particles(t, points, np.full(len(points), r), fields.vector("velocity", default=[0, 0, 0]),
                            fields.vector("omega", default=[0, 0, 0]), fields)
        self.log.info(f"created {len(points)} particles on a lattice")

    def create_random_packing(self, fields: Fields):
        t = self._type(fields)
        count = fields.integer("count", required=True, minimum=1)
        seed = fields.integer("seed", required=True, minimum=0)
        attempts = fields.integer("max_attempts", 200, minimum=1)
        region = self._region(fields)
        self._check_memory(fields, "count", count, "asks for", attempts=attempts)
        rng = np.random.Generator(np.random.PCG64([seed, 1]))
        radii = self._radii(fields, count, rng)
        points = random_packing(region, radii, seed, self.state.x, self.state.radius, attempts)
        if len(points) < count:
            raise RunFailure(f"{fields.where}: placed only {len(points)} of {count} particles without overlap "
                             f"in {attempts} attempts each; enlarge the region or lower 'count'")
        self._add_particles(t, points, radii, fields.vector("velocity", default=[0, 0, 0]),
                            fields.vector("omega", default=[0, 0, 0]), fields)
        self.log.info(f"created {len(points)} particles by random packing (seed {seed})")

    def create_modifier(self, fields: Fields):
        name = fields.string("name", required=True)
        kind = fields.string("kind", required=True, choices=("gravity", "print", "vtk", "restart"))
        mod = {"name": name, "kind": kind}
        if kind == "gravity":
            mod["acceleration"] = fields.vector("acceleration", default=[0.0, 0.0, -9.81])
        else:
            mod["every"] = fields.integer("every", required=True, minimum=1)
        if kind == "print":
            mod["file"] = fields.string("file", required=True)
            mod["quantities"] = fields.strings("quantities", required=True)
            for q in mod["quantities"]:
                if not check_quantity(q):
                    raise fields.error("quantities", f"names unknown quantity '{q}' (known: "
                                       f"{', '.join(GLOBAL_QUANTITIES)}, or e.g. z[1] for particle 1)")
            mod["series"] = None
        elif kind == "vtk":
            mod["folder"] = fields.string("folder", "post")
            mod["prefix"] = fields.string("prefix", "particles")
        elif kind == "restart":
            mod["file"] = fields.string("file", "restart_{step}.npz")
        self.modifiers[name] = mod

    def create_restart(self, fields: Fields):
        self.write_restart(fields.string("file", required=True))

    def cmd_fix(self, fields: Fields):
        name = fields.string("name", required=True)
        if name not in self.modifiers:
            raise fields.error("name", f"names no modifier '{name}' (create it first)")
        if name not in self.active:
            self.active.append(name)

    def cmd_unfix(self, fields: Fields):
        name = fields.string("name", required=True)
        if name not in self.active:
            raise fields.error("name", f"names no fixed modifier '{name}'")
        self.active.remove(name)

    def cmd_set(self, fields: Fields):
        prop = fields.string("property", required=True,
                             choices=("timestep", "skin", "thermo", "timestep_check", "restart", "velocity"))
        if prop == "timestep":
            value = fields.number("value", positive=True)
            fraction = fields.number("fraction_of_critical", positive=True)
            if (value is None) == (fraction is None):
                raise fields.error("value", "give either 'value' (s) or 'fraction_of_critical' (of min(t_R, t_H))")
            if fraction is not None:
                # a time step as a fraction of the critical one, as sweeps over accuracy ask for it
                t_c = min(self.critical_timestep())
                if not math.isfinite(t_c):
                    raise fields.error("fraction_of_critical", "needs particles to estimate the critical time step "
                                       "(create them first)")
                value = fraction * t_c
                self.log.info(f"time step {value!r} s = {fraction:g} x critical time step {t_c:.6g} s")
            self.dt = value
        elif prop == "skin":
            self.skin = fields.number("value", required=True, positive=True)
        elif prop == "thermo":
            self.thermo_every = fields.integer("every", 0, minimum=0)
            columns = fields.strings("columns", [])
            for q in columns:
                if not check_quantity(q):
                    raise fields.error("columns", f"names unknown quantity '{q}'")
            self.thermo_columns = THERMO_FIRST + [c for c in columns if c not in THERMO_FIRST]
            new_file = fields.string("file", self.thermo_file)
            if self.thermo is not None:
                self.thermo.close()
                self.thermo = None
            self.thermo_file = new_file
        elif prop == "timestep_check":
            self.timestep_fraction = fields.number("fraction", self.timestep_fraction, positive=True)
            self.timestep_strict = fields.boolean("strict", self.timestep_strict)
            self.timestep_every = fields.integer("every", self.timestep_every, minimum=0)
        elif prop == "restart":
            self.read_restart(fields.string("file", required=True), fields)
        elif prop == "velocity":
            value = fields.vector("value", required=True)
            t = fields.integer("type", None, minimum=1)
            mask = np.ones(self.n, dtype=bool) if t is None else self.state.ptype == t - 1
            if mask.any():
                heaviest = float(self.state.mass[mask].max())
                with np.errstate(all="ignore"):
                    energy = 0.5 * heaviest * float(np.dot(value, value))
                if not math.isfinite(energy):
                    raise fields.error("value", f"{value} gives a kinetic energy that is not a finite double")
            self.state.v[mask] = value
            self.dirty = True

    def cmd_get(self, fields: Fields):
        prop = fields.string("property", required=True)
        if prop == "critical_timestep":
            t_r, t_h = self.critical_timestep()
            self.log.info(f"critical_timestep: rayleigh_time = {t_r!r} s, hertz_time = {t_h!r} s")
        elif check_quantity(prop):
            self.log.info(f"{prop} = {self.quantity(prop)!r}")
        else:
            raise fields.error("property", f"names unknown property '{prop}'")

    # ------------------------------------------------------------------ quantities
    def quantity(self, name: str):
        m = _WALL_QUANTITY.match(name)
        if m:
            names = [w["name"] for w in self.walls]
            if m.group(2) not in names:
                raise InputError(f"quantity '{name}' names no wall '{m.group(2)}' (walls: {', '.join(names)})")
            k = names.index(m.group(2))
            return float(self.wall_force[k, "xyz".index(m.group(1))]) if k < len(self.wall_force) else 0.0
        m = _PARTICLE_QUANTITY.match(name)
        if m:
            s = self.state
            where = np.nonzero(s.pid == int(m.group(2)))[0]
            if len(where) == 0:
                return math.nan
            i = where[0]
            q = m.group(1)
            array = {"x": s.x, "y": s.x, "z": s.x, "vx": s.v, "vy": s.v, "vz": s.v, "fx": s.f, "fy": s.f,
                     "fz": s.f, "omegax": s.omega, "omegay": s.omega, "omegaz": s.omega}[q]
            return float(array[i, "xyz".index(q[-1])])
        s = self.state
        mass = s.mass
        if name == "step":
            return self.step
        if name == "time":
            return self.time
        if name == "atoms":
            return self.n
        if name == "ke":
            return float(0.5 * np.sum(mass * np.einsum("ij,ij->i", s.v, s.v)))
        if name == "rke":
            return float(0.5 * np.sum(0.4 * mass * s.radius ** 2 * np.einsum("ij,ij->i", s.omega, s.omega)))
        if name == "pe":
            g = self.gravity_vector()
            return float(-np.sum(mass * (s.x @ g)))
        if name == "energy":
            return self.quantity("ke") + self.quantity("rke") + self.quantity("pe")
        if name.startswith("momentum_"):
            return float(np.sum(mass * s.v[:, AXES[name[-1]]]))
        if name.startswith("com_"):
            return float(np.sum(mass * s.x[:, AXES[name[-1]]]) / np.sum(mass)) if len(mass) else math.nan
        if name == "max_speed":
            return float(np.sqrt(np.max(np.einsum("ij,ij->i", s.v, s.v)))) if len(mass) else 0.0
        if name in ("contacts", "max_overlap"):
            contacts, _, worst = self.overlaps()
            return contacts if name == "contacts" else worst
        raise KeyError(name)

    def overlaps(self):
        """(particle-particle contacts, contacts above 10 % overlap, max overlap / smaller radius)."""
        if self.lo is None or len(self.nbr.start) != self.n + 1:
            return 0, 0, 0.0
        return overlap_statistics(self.state.x, self.state.radius, self.nbr.start, self.nbr.j, self.lo, self.hi,
                                  self.periodic, OVERLAP_WARN_RATIO)

    def gravity_vector(self) -> np.ndarray:
        g = np.zeros(3)
        for name in self.active:
            if self.modifiers[name]["kind"] == "gravity":
                g += self.modifiers[name]["acceleration"]
        return g

    # ------------------------------------------------------------------ stability guards
    def critical_timestep(self):
        """(Rayleigh time, Hertz time) in s after LIGGGHTS ``fix_check_timestep_gran`` (physics.md, seed 000).

        t_R = min_i pi r sqrt(rho/G) / (0.1631 nu + 0.8766), G = Y / (2 (1+nu));
        t_H = min_i 2.87 (m^2 / (R Y*^2 v))^(1/5) with m the particle mass, R = r/2, Y* the largest over the
        types it can touch (particle types present and wall types), v = max(2 v_max, v_max + v_wall_max) with
        the plane walls' whole speed; infinite when v = 0. LIGGGHTS 3.8 takes Y* of the particle's own type
        pair only and no primitive wall's speed: README.md says why we keep the smaller, safer bound.
        Vectorised over particles (per-type lookup tables): cheap enough to re-check during a run.
        """
        s = self.state
        if self.n == 0:
            return math.inf, math.inf
        ntypes = max(self.materials)
        table = np.full((ntypes + 1, 3), np.nan)
        for t, (y_t, nu_t, rho_t) in self.materials.items():
            table[t] = (y_t, nu_t, rho_t)
        user_types = s.ptype + 1
        y, nu, rho = table[user_types, 0], table[user_types, 1], table[user_types, 2]
        shear = y / (2.0 * (1.0 + nu))
        t_r = float(np.min(math.pi * s.radius * np.sqrt(rho / shear) / (0.1631 * nu + 0.8766)))
        v_max = float(np.sqrt(np.max(np.einsum("ij,ij->i", s.v, s.v))))
        v_wall = max([float(np.linalg.norm(w["velocity"])) for w in self.walls if w["shape"] == "plane"],
                     default=0.0)
        v = max(2.0 * v_max, v_max + v_wall)
        if v == 0.0:
            return t_r, math.inf
        present = np.nonzero(np.bincount(user_types, minlength=ntypes + 1))[0].tolist()
        partners = sorted(set(present) | {w["type"] for w in self.walls})
        ystar = np.full(ntypes + 1, np.nan)
        for t in present:
            ystar[t] = max(effective_youngs_modulus(*self.materials[t][:2], *self.materials[p][:2])
                           for p in partners)
        ystar_i = ystar[user_types]
        t_h = float(np.min(2.87 * (s.mass * s.mass / (0.5 * s.radius * ystar_i * ystar_i * v)) ** 0.2))
        return t_r, t_h

    def check_timestep(self, where: str):
        """The check at run start: logs both times and the ratios; warns (strict: fails) above the fraction."""
        t_r, t_h = self.critical_timestep()
        self.log.info(f"critical time step: Rayleigh time {t_r:.6g} s (dt/t_R = {self.dt / t_r:.4g}), "
                      f"Hertz time {t_h:.6g} s (dt/t_H = {self.dt / t_h:.4g}), fraction limit "
                      f"{self.timestep_fraction:g}")
        self._timestep_verdicts(where, "", t_r, t_h, warned=set())

    def recheck_timestep(self, where: str, warned: set):
        """The re-check every `timestep_every` steps with the current speeds; each kind of warning once per run
        (warned holds the kinds already given)."""
        t_r, t_h = self.critical_timestep()
        self._timestep_verdicts(where, f"step {self.step}: ", t_r, t_h, warned)

    def _timestep_verdicts(self, where: str, prefix: str, t_r: float, t_h: float, warned: set):
        for label, t_c in (("Rayleigh", t_r), ("Hertz", t_h)):
            if self.dt > self.timestep_fraction * t_c and label not in warned:
                text = (f"{prefix}time step {self.dt:g} s is {self.dt / t_c:.3g} of the {label} time {t_c:.4g} s, "
                        f"above the allowed fraction {self.timestep_fraction:g}")
                if self.timestep_strict:
                    raise RunFailure(f"{where}: {text} (strict time step check)")
                warned.add(label)
                self.log.warning(text)
        s = self.state
        if self.n and "skin" not in warned:
            v_max = float(np.sqrt(np.max(np.einsum("ij,ij->i", s.v, s.v))))
            if 2.0 * v_max * self.dt > self.skin:
                warned.add("skin")
                self.log.warning(f"{prefix}relative velocity {2 * v_max:.4g} m/s times dt exceeds the neighbor "
                                 f"skin {self.skin:g} m; contacts may be missed")

    def wall_overlaps(self):
        """(particle-wall contacts above 10 % of the radius, largest overlap / radius) over all walls, vectorised.

        Plane along axis a at p: overlap r - |x_a - p| (two-sided); z-cylinder: r - (R - rho) inside,
        r - (rho - R) outside, rho the distance from its axis (physics.md, walls).
        """
        if not self.walls or self.n == 0:
            return 0, 0.0
        ratio = overlap_ratios(self.walls, self.plane_pos, self.state.x, self.state.radius)
        return int(np.count_nonzero(ratio > OVERLAP_WARN_RATIO)), max(0.0, float(ratio.max()))

    # ------------------------------------------------------------------ run
    def combination(self) -> Combination:
        m = self.model
        return Combination(normal=m["normal"], tangential=m["tangential"], cohesion=m["cohesion"],
                           rolling=m["rolling"], limit_force=m["limit_force"],
                           tangential_damping=m["tangential_damping"],
                           planes=any(w["shape"] == "plane" for w in self.walls),
                           cylinders=any(w["shape"] == "cylinder" for w in self.walls),
                           gravity=any(self.modifiers[n]["kind"] == "gravity" for n in self.active),
                           periodic=tuple(bool(p) for p in self.periodic))

    def _check_ready(self, fields: Fields):
        if self.lo is None:
            raise fields.error("steps", "cannot run: no domain (create a domain first)")
        if self.dt is None:
            raise fields.error("steps", "cannot run: no time step (set property timestep first)")
        if self.model is None:
            raise fields.error("steps", "cannot run: no contact model (create a contact_model first)")
        used = sorted(set((self.state.ptype + 1).tolist()) | {w["type"] for w in self.walls})
        for a in used:
            for b in used:
                if a <= b and (a, b) not in self.interactions:
                    raise fields.error("steps", f"cannot run: no interaction for material types {a} and {b} "
                                       "(create an interaction)")
        names = {w["name"] for w in self.walls}
        requested = list(self.thermo_columns) + [q for n in self.active for q in self.modifiers[n].get("quantities", [])]
        for q in requested:
            m = _WALL_QUANTITY.match(q)
            if m and m.group(2) not in names:
                raise fields.error("steps", f"cannot run: quantity '{q}' names no wall '{m.group(2)}' "
                                   f"(walls: {', '.join(sorted(names)) or 'none'})")
        if self.n:
            cutoff = 2 * float(self.state.radius.max()) + self.skin
            for a in range(3):
                if self.periodic[a] and self.hi[a] - self.lo[a] < 2 * cutoff:
                    raise fields.error("steps", f"cannot run: periodic length along {'xyz'[a]} must be at least "
                                       f"twice the neighbor cutoff ({2 * cutoff:g} m)")

    @property
    def n(self) -> int:
        """Number of particles."""
        return particle_state.count(self.state)

    def _fit_history(self, combo: Combination):
        """History arrays sized for this combination: width 0 (nothing stored) unless a submodel needs it."""
        width = combo.history_width
        nbr = self.nbr
        if len(nbr.start) > self.n + 1:  # stale list after particles vanished: start afresh
            nbr = empty_list(width)
        if nbr.hist.shape != (len(nbr.j) if width else 0, width):
            nbr = nbr._replace(hist=np.zeros((len(nbr.j) if width else 0, width)))
        self.nbr = nbr
        self.state = particle_state.fit_wall_history(self.state, len(self.walls), width)

    def _report_lost(self, lost, where: str, started_with: int):
        """Warn with count and ids; a run that started with particles and has none left fails (LIGGGHTS
        stops with "Lost atoms" by default): an empty simulation is broken physics, not a result."""
        lost_ids, lost_steps, nlost = lost.ids, lost.steps, int(lost.count[0])
        if nlost:
            ids = ", ".join(str(i) for i in lost_ids[:nlost][:20]) + (" ..." if nlost > 20 else "")
            self.log.warning(f"{nlost} particle(s) left the fixed domain and were removed (ids {ids}; first at "
                             f"step {int(lost_steps[0])})")
            self.lost_total += nlost
            if started_with and self.n == 0:
                raise RunFailure(f"{where}: all {started_with} particles present at the start of the run left the "
                                 f"fixed domain (the last at step {int(lost_steps[nlost - 1])}); nothing is left "
                                 "to simulate")

    def total_line(self) -> str:
        """The log's last line after a successful script."""
        return (f"total: {self.timing['steps']} steps, {self.n} particles, {self.lost_total} lost, "
                f"{self.log.warnings} warning(s)")

    def cmd_run(self, fields: Fields):
        steps = fields.integer("steps", required=True, minimum=0)
        self._check_ready(fields)
        combo = self.combination()
        t0 = time.perf_counter()
        kernel = build_kernel(combo)
        self._fit_history(combo)
        self.check_timestep(fields.where)
        pp = parameter_table(combo, self.materials, self.interactions, max(self.materials))
        gravity = self.gravity_vector()
        if self.wall_force.shape[0] != len(self.walls):
            self.wall_force = np.zeros((len(self.walls), 3))
        walls = wall_set(self.walls, self.plane_pos, self.wall_force)
        constants = Constants(dt=self.dt, characteristic_velocity=self.model["characteristic_velocity"],
                              gravity=gravity, lo=self.lo, hi=self.hi, periodic=self.periodic, skin=self.skin)
        started_with = self.n
        created = self.dirty
        if self.dirty:
            lost = lost_record(self.n)
            n, self.nbr = kernel.setup(self.state, self.n, self.nbr, walls, pp, constants, self.step, lost)
            self.state = particle_state.trimmed(self.state, n)
            self._report_lost(lost, fields.where, started_with)
            self.dirty = False
        # a zero-step call compiles run_steps (or loads it from the disk cache) outside the timed loop
        kernel.run_steps(self.state, self.n, self.nbr, walls, pp, constants, self.step, 0, np.zeros(3),
                         lost_record(0))
        # the overlap check between chunks is compiled too: not inside the timed loop
        _, n_large, worst = self.overlaps()
        self.timing["compile"] += time.perf_counter() - t0  # first call of a kernel compiles or loads it
        overlap_warned = False
        max_overlap = worst
        if created:
            # particles created (or restored) overlapping: the run would start with a violent push apart; say
            # so as the run-time check does (that one only looks after the first chunk of steps)
            if n_large:
                self.log.warning(f"step {self.step}: {n_large} contact(s) overlap more than "
                                 f"{OVERLAP_WARN_RATIO:.0%} of the smaller radius (max {worst:.1%}) at the start "
                                 "of the run")
            n_wall, worst_wall = self.wall_overlaps()
            if n_wall:
                self.log.warning(f"step {self.step}: {n_wall} particle-wall contact(s) overlap more than "
                                 f"{OVERLAP_WARN_RATIO:.0%} of the radius (max {worst_wall:.1%}) at the start of "
                                 "the run")
        start_wall = time.perf_counter()
        start_cpu = time.process_time()  # CPU seconds too: on a shared machine wall time overstates the cost
        start_step, start_time = self.step, self.time
        timers = np.zeros(3)
        particle_steps = 0
        rebuilds = 0
        self._where = fields.where
        self._outputs(start=True)
        timestep_warned: set = set()
        end = start_step + steps
        self._end_step = end
        while self.step < end:
            stop = self._next_output_step(end)
            n = self.n
            lost = lost_record(n)
            status, bad, done, rebuilt, kept, self.nbr = kernel.run_steps(
                self.state, n, self.nbr, walls, pp, constants, self.step, stop - self.step, timers, lost)
            self.state = particle_state.trimmed(self.state, kept)
            particle_steps += done * n
            rebuilds += rebuilt
            self.step += done
            self.time = start_time + (self.step - start_step) * self.dt
            if status == 1:
                self.step += 1
                raise RunFailure(f"{fields.where}: non-finite position of particle {int(self.state.pid[bad])} at step "
                                 f"{self.step}")
            self._report_lost(lost, fields.where, started_with)
            self._check_finite(fields.where)
            _, n_large, worst = self.overlaps()
            max_overlap = max(max_overlap, worst)
            if n_large and not overlap_warned:
                overlap_warned = True
                self.log.warning(f"step {self.step}: {n_large} contact(s) overlap more than "
                                 f"{OVERLAP_WARN_RATIO:.0%} of the smaller radius (max {worst:.1%})")
            if self.timestep_every and self.step % self.timestep_every == 0:
                self.recheck_timestep(fields.where, timestep_warned)
            self._outputs(start=False)
        total = time.perf_counter() - start_wall
        cpu = time.process_time() - start_cpu
        t = self.timing
        t["neigh"] += timers[0]
        t["pair"] += timers[1]
        t["modify"] += timers[2]
        t["total"] += total
        t["cpu"] += cpu
        t["steps"] += steps
        t["particles"] = self.n
        t["particle_steps"] += particle_steps
        rate = particle_steps / total if total > 0 else 0.0
        self.log.info(f"Loop time of {total:.6g} s for {steps} steps with {self.n} particles "
                      f"({rate:.4g} particle-steps/s); pair {timers[1]:.4g} s, neigh {timers[0]:.4g} s "
                      f"({rebuilds} rebuilds), modify {timers[2]:.4g} s; max overlap {max_overlap:.2%} of radius; "
                      f"particles lost so far {self.lost_total}; cpu {cpu:.6g} s "
                      f"({particle_steps / cpu if cpu > 0 else 0.0:.4g} particle-steps per cpu second)")

    def _check_finite(self, where):
        """Positions, velocities, forces, spins and the kinetic energies they give must be finite doubles: a
        speed of 1e200 m/s is finite, its 0.5 m v^2 is not, and thermo would print inf."""
        s = self.state
        with np.errstate(all="ignore"):
            kinetic = 0.5 * s.mass * np.einsum("ij,ij->i", s.v, s.v)
            rotational = 0.2 * s.mass * s.radius ** 2 * np.einsum("ij,ij->i", s.omega, s.omega)
        for label, array in (("velocity", s.v), ("force", s.f), ("angular velocity", s.omega),
                             ("position", s.x), ("kinetic energy", kinetic), ("rotational energy", rotational)):
            finite = np.isfinite(array) if array.ndim == 1 else np.all(np.isfinite(array), axis=1)
            bad = np.nonzero(~finite)[0]
            if len(bad):
                raise RunFailure(f"{where}: non-finite {label} of particle {int(s.pid[bad[0]])} at step "
                                 f"{self.step}")

    def _output_every(self):
        every = [self.thermo_every] if self.thermo_every else []
        every += [self.modifiers[n]["every"] for n in self.active if "every" in self.modifiers[n]]
        return every

    def _next_output_step(self, end):
        """The next step at which Python looks at the state: an output, a time step re-check, or the end."""
        stop = end
        for every in self._output_every() + ([self.timestep_every] if self.timestep_every else []):
            stop = min(stop, (self.step // every + 1) * every)
        return stop

    def _row(self, columns):
        """Values of output columns; a global quantity that is not finite stops the run instead of reaching a
        file (per-particle quantities of an absent id are NaN by design, as is com_* without particles)."""
        values = [self.quantity(c) for c in columns]
        for c, value in zip(columns, values):
            if (isinstance(value, float) and not math.isfinite(value) and _PARTICLE_QUANTITY.match(c) is None
                    and not (c.startswith("com_") and self.n == 0)):
                raise RunFailure(f"{self._where}: non-finite {c} ({value}) at step {self.step}")
        return values

    def _outputs(self, start: bool):
        t0 = time.perf_counter()
        if self.thermo is None:
            self.thermo = CsvSeries(self.thermo_file, self.thermo_columns, "thermo file")
        # rows at run start, every N steps and at run end, like LIGGGHTS' thermo
        if start or (self.thermo_every and self.step % self.thermo_every == 0) or self.step == self._end_step:
            self.thermo.write(self.step, self._row(self.thermo_columns))
        for name in self.active:
            mod = self.modifiers[name]
            if "every" not in mod or self.step % mod["every"]:
                continue
            if mod["kind"] == "print":
                if mod["series"] is None:
                    mod["series"] = CsvSeries(mod["file"], ["step", "time"] + mod["quantities"], "print file")
                mod["series"].write(self.step, self._row(["step", "time"] + mod["quantities"]))
            elif mod["kind"] == "vtk":
                self.write_vtk(mod)
            elif mod["kind"] == "restart" and not start:
                self.write_restart(mod["file"].replace("{step}", str(self.step)))
        self.timing["output"] += time.perf_counter() - t0

    _end_step = None
    _where = ""

    def write_vtk(self, mod):
        folder = Path(mod["folder"])
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise output_failure("VTK dump folder", folder, exc) from None
        s = self.state
        order = np.argsort(s.pid, kind="stable")  # files list particles by id, whatever the memory order
        write_vtp(folder / f"{mod['prefix']}_{self.step}.vtp", s.pid[order], s.ptype[order] + 1, s.x[order],
                  s.v[order], s.f[order], s.omega[order], s.radius[order])

    # ------------------------------------------------------------------ restart
    def write_restart(self, path: str):
        """Everything needed to continue bitwise: particles in memory order, neighbor list, contact history."""
        if self.lo is None:
            raise InputError(f"restart {path}: nothing to write (no domain yet)")
        try:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            with open(path, "wb") as handle:
                np.savez(handle, format=RESTART_FORMAT, step=self.step, time=self.time,
                         dt=np.nan if self.dt is None else self.dt, skin=self.skin, lo=self.lo, hi=self.hi,
                         periodic=self.periodic, next_id=self.next_id, dirty=self.dirty,
                         walls=json.dumps(self.walls), plane_pos=self.plane_pos, wall_force=self.wall_force,
                         **particle_state.as_arrays(self.state),
                         **{key: getattr(self.nbr, name) for key, name in NEIGHBOR_ARRAYS.items()})
        except OSError as exc:
            raise output_failure("restart file", path, exc) from None
        self.log.info(f"wrote restart file {path} at step {self.step}")

    def read_restart(self, path: str, fields: Fields):
        """Restore a restart file, after checking that it is one: a truncated, foreign or inconsistent file
        must be bad input, never a crash, and never arrays whose sizes disagree reaching the compiled kernel
        (which does not check bounds)."""
        try:
            data = _load_restart(path)
        except OSError as exc:
            raise fields.error("file", f"cannot read restart file {path}: {exc.strerror or exc}") from None
        except Exception as exc:  # noqa: BLE001 - whatever a broken archive raises, the file is the problem
            raise fields.error("file", f"{path} is not a readable restart file ({type(exc).__name__}: "
                               f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
        if data.get("format") is None or data["format"].shape != () or data["format"].dtype.kind not in "iu":
            raise fields.error("file", f"{path} is not a restart file of this engine (no format number)")
        if int(data["format"]) != RESTART_FORMAT:
            raise fields.error("file", f"{path} has restart format {int(data['format'])}, expected {RESTART_FORMAT}")
        try:
            walls = _check_restart(data)
        except ValueError as exc:
            raise fields.error("file", f"{path} is not a consistent restart file: {exc}") from None
        for w in walls:
            if w["type"] not in self.materials:
                raise fields.error("file", f"wall '{w['name']}' in {path} uses material type {w['type']} "
                                   "which this script does not define")
        for t in set((data["ptype"] + 1).tolist()):
            if t not in self.materials:
                raise fields.error("file", f"{path} holds particles of material type {t} which this script "
                                   "does not define")
        self.step = int(data["step"])
        self.time = float(data["time"])
        if not math.isnan(float(data["dt"])):
            self.dt = float(data["dt"])
        self.skin = float(data["skin"])
        self.lo, self.hi = data["lo"].copy(), data["hi"].copy()
        self.periodic = data["periodic"].copy()
        self.next_id = int(data["next_id"])
        self.walls = walls
        self.plane_pos = data["plane_pos"].copy()
        self.wall_force = data["wall_force"].copy()
        self.state = particle_state.from_arrays(data)
        self.nbr = NeighborList(**{name: np.ascontiguousarray(data[key]) for key, name in NEIGHBOR_ARRAYS.items()})
        self.dirty = bool(data["dirty"])
        self.log.info(f"read restart file {path}: step {self.step}, {self.n} particles")

    def close(self):
        if self.thermo is not None:
            self.thermo.close()
        for mod in self.modifiers.values():
            if mod.get("series") is not None:
                mod["series"].close()

    def timing_record(self) -> dict:
        t = dict(self.timing)
        t["other"] = max(0.0, t["total"] - t["pair"] - t["neigh"] - t["comm"] - t["modify"] - t["output"])
        t["particle_steps_per_second"] = t["particle_steps"] / t["total"] if t["total"] > 0 else 0.0
        return t


def _load_restart(path: str) -> dict:
    """All arrays of a restart file (.npz), read eagerly so that a truncated member fails here."""
    archive = np.load(path, allow_pickle=False)
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise ValueError("a single .npy array, not an .npz archive")
    with archive:
        return {key: archive[key] for key in archive.files}


#: restart arrays: name -> (dtype kind, shape with "n" for the particle count)
_RESTART_SHAPES = {
    "x": ("f", ("n", 3)), "v": ("f", ("n", 3)), "f": ("f", ("n", 3)), "omega": ("f", ("n", 3)),
    "torque": ("f", ("n", 3)), "x_build": ("f", ("n", 3)), "radius": ("f", ("n",)), "mass": ("f", ("n",)),
    "inv_mass": ("f", ("n",)), "inv_inertia": ("f", ("n",)), "ptype": ("i", ("n",)), "pid": ("i", ("n",)),
    "nbr_start": ("i", (None,)), "nbr_j": ("i", (None,)), "pair_hist": ("f", (None, None)),
    "wall_hist": ("f", (None, None, None)), "step": ("i", ()), "time": ("f", ()), "dt": ("f", ()),
    "skin": ("f", ()), "lo": ("f", (3,)), "hi": ("f", (3,)), "periodic": ("b", (3,)), "next_id": ("i", ()),
    "dirty": ("b", ()), "walls": ("U", ()), "plane_pos": ("f", (None,)), "wall_force": ("f", (None, 3)),
}


def _check_restart(data: dict) -> list[dict]:
    """ValueError naming the first inconsistency of a restart file's arrays; returns its walls."""
    missing = sorted(set(_RESTART_SHAPES) - set(data))
    if missing:
        raise ValueError(f"missing {', '.join(missing)}")
    n = data["pid"].shape[0] if data["pid"].ndim == 1 else -1
    for key, (kind, shape) in _RESTART_SHAPES.items():
        a = data[key]
        want = tuple(n if d == "n" else d for d in shape)
        if (a.dtype.kind != kind or a.ndim != len(want)
                or any(w is not None and w != s for w, s in zip(want, a.shape))):
            raise ValueError(f"array '{key}' has dtype {a.dtype} and shape {a.shape}, expected kind '{kind}' and "
                             f"shape {tuple('N' if d == 'n' else ('*' if d is None else d) for d in shape)}")
        if kind == "f" and key != "dt" and not np.all(np.isfinite(a)):  # dt is NaN when none was set
            raise ValueError(f"array '{key}' holds non-finite values")
    if data["wall_hist"].shape[0] not in (0, n) or (data["wall_hist"].shape[0] == 0 and data["wall_hist"].size):
        raise ValueError(f"array 'wall_hist' has {data['wall_hist'].shape[0]} rows for {n} particles")
    if data["wall_hist"].shape[0] != n:  # written without wall history: none, for every particle
        data["wall_hist"] = np.zeros((n, 0, 0))
    if np.any(data["radius"] <= 0) or np.any(data["mass"] <= 0) or np.any(data["ptype"] < 0):
        raise ValueError("a particle with radius, mass or type out of range")
    if int(data["step"]) < 0 or not np.all(data["hi"] > data["lo"]) or float(data["skin"]) <= 0:
        raise ValueError("step, domain or skin out of range")
    pid = data["pid"]
    if len(np.unique(pid)) != n or (n and (pid.min() < 1 or pid.max() >= int(data["next_id"]))):
        raise ValueError("particle ids are not unique or not below next_id")
    start, j = data["nbr_start"], data["nbr_j"]
    if (not 1 <= len(start) <= n + 1 or start[0] != 0 or np.any(np.diff(start) < 0) or start[-1] != len(j)
            or (len(j) and (j.min() < 0 or j.max() >= n))):
        raise ValueError("the neighbor list does not fit the particles")
    try:
        walls = json.loads(str(data["walls"]))
    except ValueError as exc:
        raise ValueError(f"the wall list is not JSON ({exc})") from None
    if not isinstance(walls, list) or not all(_wall_ok(w) for w in walls):
        raise ValueError("the wall list is not a list of wall definitions")
    planes = sum(1 for w in walls if w["shape"] == "plane")
    if data["plane_pos"].shape[0] != planes:
        raise ValueError(f"{data['plane_pos'].shape[0]} plane positions for {planes} planes")
    return walls


def _wall_ok(w) -> bool:
    def numbers(value, k):
        return isinstance(value, list) and len(value) == k and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not (isinstance(w, dict) and isinstance(w.get("name"), str) and isinstance(w.get("type"), int)):
        return False
    if w.get("shape") == "plane":
        return w.get("axis") in (0, 1, 2) and numbers([w.get("position")], 1) and numbers(w.get("velocity"), 3)
    return (w.get("shape") == "cylinder" and numbers(w.get("center"), 2) and numbers([w.get("radius")], 1)
            and w.get("side") in ("inside", "outside"))
