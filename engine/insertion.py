"""Particles inserted during a run (modifier `insert`) and removed by outlets (modifier `outlet`).

**Insertion** (after LIGGGHTS' fix insert/rate/region with fix particledistribution/discrete): at each of its
steps (multiples of `every` from `start` on) an insert modifier supplies the particles of the next `every`
steps: after insertion number k (from 0) the cumulative target is ``floor(rate * T_k)`` particles or
``mass_rate * T_k`` kg, T_k = the time of the k+1 intervals supplied so far (every x dt each), capped by
`total` / `total_mass`; it inserts the target minus what it inserted before. So a run of S steps starting at
an insertion step inserts rate x (S + every) dt particles: the last insertion is at the run's last step and
already supplies the next interval (LIGGGHTS inserts at the first step of the run and then every N steps).

Radii come from a distribution (`Distribution`) drawn from numpy's PCG64 seeded with (seed, k, 1), positions
from `engine.scene.random_packing` seeded with (seed, k, 2) in the modifier's region, never overlapping a
particle already there nor a wall (a place that would overlap a wall - a region cutting into a hopper's mesh -
is left out): the same seed gives the same particles, on any thread count, and a restart that
carries the counters (`state`) continues with insertion k + 1 as the long run does. What does not fit is
carried over to the next insertion (one warning per modifier). In mass mode the radii are drawn one after the
other while the next particle still fits under the target, so the inserted mass trails the target by less
than one particle's mass.

**Outlets** remove the particles whose centre lies in their region at each of their steps; removing is not
losing (`sim.lost_total` counts only particles that left the domain).

Both change the particle set through `engine.particle_set`, which keeps the neighbor list and the contact
history of every surviving pair.
"""
from __future__ import annotations

import math

import numpy as np

from . import clumps, particle_set, regions
from .scene import random_packing
from .walls import overlap_ratios
from .script import Fields

#: tolerance on the particle count target rate x time (in particles): time accumulated in steps of every x dt
#: is not exact in binary, and 2000/s x 0.05 s must give 100, not 99
COUNT_TOLERANCE = 1e-6
DISTRIBUTIONS = ("uniform", "normal", "lognormal", "discrete")
#: truncated distributions draw until enough samples fall in [min, max]: refuse ranges that hold less than
#: this probability (the draw would take forever)
MIN_TRUNCATED_PROBABILITY = 1e-6


def sphere_mass(density: float, radii):
    """m = rho 4/3 pi r^3 (kg), as `commands.add_particles` computes it."""
    return density * 4.0 / 3.0 * math.pi * np.asarray(radii, dtype=np.float64) ** 3


class Distribution:
    """Radii (m) of inserted particles: a constant, or `kind` uniform, normal, lognormal (both truncated to
    [min, max]) or discrete (radii with mass fractions; the number probability of radius i is
    f_i / m_i / sum_j f_j / m_j, m_i ~ r_i^3: LIGGGHTS' particledistribution/discrete takes mass fractions)."""

    def __init__(self, fields: Fields, name: str):
        self.kind = fields.string("kind", required=True, choices=DISTRIBUTIONS)
        if self.kind == "discrete":
            self.radii = np.array(self._positive_list(fields, "radii"))
            fractions = np.array(self._positive_list(fields, "mass_fractions"))
            if len(fractions) != len(self.radii):
                raise fields.error("mass_fractions", f"must have one entry per radius ({len(self.radii)})")
            fractions = fractions / fractions.sum()
            weights = fractions / self.radii ** 3
            self.probabilities = weights / weights.sum()
            self.min, self.max = float(self.radii.min()), float(self.radii.max())
            return
        if self.kind == "uniform":
            self.min = fields.number("min", required=True, positive=True)
            self.max = fields.number("max", required=True, positive=True)
        else:
            centre = "mean" if self.kind == "normal" else "median"
            self.centre = fields.number(centre, required=True, positive=True)
            self.spread = fields.number("sd" if self.kind == "normal" else "sigma", required=True, positive=True)
            self.min = fields.number("min", required=True, positive=True)
            self.max = fields.number("max", required=True, positive=True)
        if self.max < self.min:
            raise fields.error("max", f"must be >= min ({self.min:g})")
        if self.kind in ("normal", "lognormal") and self._probability_in_range() < MIN_TRUNCATED_PROBABILITY:
            raise fields.error("min", f"[{self.min:g}, {self.max:g}] holds almost none of the {self.kind} "
                               "distribution (probability below 1e-6); widen it")

    @staticmethod
    def _positive_list(fields: Fields, name: str) -> list:
        value = fields.raw(name, required=True)
        if not (isinstance(value, list) and value and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
                for v in value)):
            raise fields.error(name, "must be a non-empty list of positive numbers")
        return [float(v) for v in value]

    def _z(self, r: float) -> float:
        return (r - self.centre) / self.spread if self.kind == "normal" else (
            (math.log(r) - math.log(self.centre)) / self.spread)

    def _probability_in_range(self) -> float:
        phi = lambda z: 0.5 * math.erfc(-z / math.sqrt(2.0))  # noqa: E731 - the normal CDF
        return phi(self._z(self.max)) - phi(self._z(self.min))

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """count radii (m) drawn from rng."""
        if count <= 0:
            return np.zeros(0)
        if self.kind == "discrete":
            return self.radii[rng.choice(len(self.radii), size=count, p=self.probabilities)]
        if self.kind == "uniform":
            return self.min + (self.max - self.min) * rng.random(count)
        out = np.empty(0)
        while len(out) < count:  # rejection: draws outside [min, max] are dropped, in stream order
            draw = rng.normal(self.centre if self.kind == "normal" else math.log(self.centre), self.spread,
                              size=2 * (count - len(out)) + 16)
            if self.kind == "lognormal":
                draw = np.exp(draw)
            out = np.concatenate([out, draw[(draw >= self.min) & (draw <= self.max)]])
        return out[:count]


class Constant:
    """All radii equal."""

    def __init__(self, radius: float):
        self.min = self.max = radius

    def sample(self, rng, count: int) -> np.ndarray:
        return np.full(max(count, 0), self.min)


def radii_of(fields: Fields):
    """`radius` (m) or `radius_distribution` {kind, ...} of an insert modifier."""
    if fields.has("radius") == fields.has("radius_distribution"):
        raise fields.error("radius", "give either 'radius' (m) or 'radius_distribution' ({\"kind\": ...})")
    if fields.has("radius"):
        return Constant(fields.number("radius", required=True, positive=True))
    sub = Fields(fields.mapping("radius_distribution", required=True), fields.where + ", radius_distribution")
    dist = Distribution(sub, "radius_distribution")
    sub.finish()
    return dist


def clump_template_of(sim, fields: Fields):
    """The clump template an insert modifier names in `template` (and the bodies it will add to), or None."""
    name = fields.string("template", None)
    if name is None:
        return None
    if name not in sim.clump_templates:
        raise fields.error("template", f"names no clump template '{name}' (templates: "
                           f"{', '.join(sorted(sim.clump_templates)) or 'none'})")
    if sim.bodies is None:  # the run compiles the clump kernels from its start on
        sim.bodies = clumps.empty_bodies(sim.next_id)
    return sim.clump_templates[name]


class Inserter:
    """The state and the insertion step of one insert modifier (see the module docstring)."""

    def __init__(self, name: str, fields: Fields, sim):
        self.name = name
        self.every = fields.integer("every", required=True, minimum=1)
        # clumps of a template (engine/clumps.py) instead of spheres: their material is the template's
        self.template = clump_template_of(sim, fields)
        t = self.template.type if self.template else fields.integer("type", required=True, minimum=1)
        if t not in sim.materials:
            raise fields.error("type", f"names unknown material type {t} (create a material with this type "
                               "first)")
        self.type = t
        self.density = sim.materials[t][2]
        self.region = regions.region_of(fields, sim.regions)
        if fields.has("rate") == fields.has("mass_rate"):
            raise fields.error("rate", "give either 'rate' (particles/s) or 'mass_rate' (kg/s)")
        self.rate = fields.number("rate", None, positive=True)
        self.mass_rate = fields.number("mass_rate", None, positive=True)
        if fields.has("total") and fields.has("total_mass"):
            raise fields.error("total", "give at most one of 'total' (particles) and 'total_mass' (kg)")
        self.total = fields.integer("total", None, minimum=0)
        self.total_mass = fields.number("total_mass", None, minimum=0.0)
        self.start = fields.integer("start", 0, minimum=0)
        # a template's clumps are placed as their bounding spheres (no overlap with anything there)
        self.radii = Constant(self.template.bounding_radius) if self.template else radii_of(fields)
        self.velocity = np.array(fields.vector("velocity", default=[0.0, 0.0, 0.0]))
        self.omega = np.array(fields.vector("omega", default=[0.0, 0.0, 0.0]))
        self.seed = fields.integer("seed", required=True, minimum=0)
        self.max_attempts = fields.integer("max_attempts", 200, minimum=1)
        self._check_values(fields)
        lo, hi = regions.bounds(self.region)
        if np.any(hi - lo < 2 * self.radii.max):
            raise fields.error("region", f"is too small for a sphere of radius {self.radii.max:g} m")
        # counters (restart files carry them: `state`)
        self.inserted_count = 0
        self.inserted_mass = 0.0
        self.insertions = 0  # insertion number k of the next insertion (seeds its random streams)
        self.supplied_time = 0.0  # s, the intervals supplied so far
        self.last_step = -1  # the step of the last insertion: a step is never served twice
        self.warned = False

    def _check_values(self, fields: Fields):
        """The largest and smallest particles must have finite masses, inverses and energies (as created
        particles must: `commands.check_particle_values`)."""
        with np.errstate(all="ignore"):
            for r in (self.radii.min, self.radii.max):
                m = float(sphere_mass(self.density, r))
                inertia = 0.4 * m * r * r
                if not (math.isfinite(m) and m > 0 and math.isfinite(1 / m) and inertia > 0
                        and math.isfinite(1 / inertia)):
                    raise fields.error("radius", f"{r:g} m with density {self.density:g} kg/m^3 gives a mass "
                                       f"{m:.3g} kg whose inverse or inverse moment of inertia is not finite")
                for name, inert, value in (("velocity", m, self.velocity), ("omega", inertia, self.omega)):
                    if not math.isfinite(0.5 * inert * float(np.dot(value, value))):
                        raise fields.error(name, f"{value.tolist()} gives an energy that is not a finite double")

    def problem(self, sim) -> str | None:
        """Why a run cannot use this modifier (its region outside the fixed domain), or None."""
        lo, hi = regions.bounds(self.region)
        for a in range(3):
            if not sim.periodic[a] and (lo[a] < sim.lo[a] or hi[a] > sim.hi[a]):
                return (f"inserts into a region reaching beyond the domain along {'xyz'[a]} ([{lo[a]:g}, "
                        f"{hi[a]:g}] m, domain [{sim.lo[a]:g}, {sim.hi[a]:g}] m): its particles would be lost")
        return None

    def due(self, step: int) -> bool:
        return step >= self.start and step % self.every == 0 and step != self.last_step

    def _mass(self, radii) -> np.ndarray:
        """kg: of spheres of these radii, or of as many clumps of the template."""
        if self.template is not None:
            return np.full(np.shape(radii), self.template.mass)
        return sphere_mass(self.density, radii)

    def _radii(self, rng) -> np.ndarray:
        """Radii of this insertion: what the cumulative target still asks for (module docstring)."""
        if self.rate is not None:
            target = math.floor(self.rate * self.supplied_time + COUNT_TOLERANCE)
            if self.total is not None:
                target = min(target, self.total)
            return self.radii.sample(rng, target - self.inserted_count)
        target = self.mass_rate * self.supplied_time
        if self.total_mass is not None:
            target = min(target, self.total_mass)
        room = target - self.inserted_mass
        taken: list = []
        while True:  # one particle after the other, while the next still fits under the target
            batch = max(16, int(2 * room / float(self._mass(self.radii.max))) + 16)
            draw = self.radii.sample(rng, batch)
            mass = self._mass(draw)
            cumulative = np.cumsum(mass)
            fits = int(np.searchsorted(cumulative, room, side="right"))
            taken.append(draw[:fits])
            if fits < batch:
                break
            room -= float(cumulative[-1])
        return np.concatenate(taken)

    def act(self, sim) -> int:
        """Insert at the current step if it is one of this modifier's; returns the number inserted."""
        step = sim.step
        if not self.due(step):
            return 0
        k = self.insertions
        self.insertions += 1
        self.last_step = step
        self.supplied_time += self.every * sim.dt
        radii = self._radii(np.random.Generator(np.random.PCG64([self.seed, k, 1])))
        if len(radii) == 0:
            return 0
        wanted = len(radii)
        points = random_packing(self.region, radii, [self.seed, k, 2], sim.state.x, sim.state.radius,
                                self.max_attempts)
        radii = radii[:len(points)]
        if sim.walls and len(points):  # nor overlapping a wall (a region cutting into a hopper's mesh)
            clear = ~np.any(overlap_ratios(sim, points, radii) > 0.0, axis=0)
            points, radii = points[clear], radii[clear]
        placed = len(points)
        if placed < wanted and not self.warned:
            self.warned = True
            sim.log.warning(f"step {step}: insert modifier '{self.name}' placed only {placed} of {wanted} "
                            f"particles without overlap (with particles or walls) in its region "
                            f"({self.max_attempts} attempts each); the rest is carried over to its next insertions "
                            "(warned once)")
        if placed == 0:
            return 0
        mass = self._mass(radii)
        if self.template is not None:  # random orientations, seeded with (seed, k, 3)
            q = clumps.random_quaternions(np.random.Generator(np.random.PCG64([self.seed, k, 3])), placed)
            clumps.add_bodies(sim, self.template, points, q, self.velocity, self.omega, mid_run=True)
            self.inserted_count += placed
            self.inserted_mass += float(np.sum(mass))
            return placed
        gravity = sim.gravity_vector()
        particle_set.insert(
            sim, x=points, v=np.tile(self.velocity, (placed, 1)), omega=np.tile(self.omega, (placed, 1)),
            radius=radii, mass=mass, inv_mass=1.0 / mass, inv_inertia=1.0 / (0.4 * mass * radii ** 2),
            ptype=np.full(placed, self.type - 1, dtype=np.int64),
            pid=np.arange(sim.next_id, sim.next_id + placed, dtype=np.int64),
            # the force of their position now: gravity (they touch nothing), so that the next step's first
            # half kick is the one of a particle that was there all along
            f=mass[:, None] * gravity[None, :])
        sim.next_id += placed
        self.inserted_count += placed
        self.inserted_mass += float(np.sum(mass))
        return placed

    STATE = ("inserted_count", "inserted_mass", "insertions", "supplied_time", "last_step", "warned")


class Outlet:
    """The state and the removal step of one outlet modifier."""

    def __init__(self, name: str, fields: Fields, sim):
        self.name = name
        self.every = fields.integer("every", required=True, minimum=1)
        self.region = regions.region_of(fields, sim.regions)
        self.removed_count = 0
        self.removed_mass = 0.0
        self.last_step = -1

    def problem(self, sim) -> str | None:
        return None

    def due(self, step: int) -> bool:
        return step % self.every == 0 and step != self.last_step

    def act(self, sim) -> int:
        """Remove the particles whose centre is in the region, if this is one of the outlet's steps."""
        if not self.due(sim.step):
            return 0
        self.last_step = sim.step
        inside = clumps.whole_bodies(sim, regions.contains(self.region, sim.state.x))  # whole clumps
        if not inside.any():
            return 0
        if sim.bodies is None:
            self.removed_mass += float(np.sum(sim.state.mass[inside]))
        else:  # a clump's members carry its whole mass each: count the bodies' masses
            self.removed_mass += float(np.sum(clumps.masses_and_positions(sim, inside)[0]))
        removed = particle_set.remove(sim, ~inside)
        clumps.recount(sim)
        self.removed_count += removed
        return removed

    STATE = ("removed_count", "removed_mass", "last_step")
