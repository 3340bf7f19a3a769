"""Guards: what stops a run, or warns, instead of letting broken physics pass silently.

The critical time step (at run start and every `timestep_every` steps), overlaps at the start of a run,
non-finite values, particles lost from a fixed box. All vectorised numpy over the particles, evaluated only
where the compiled step loop hands back to Python.
"""
from __future__ import annotations

import math

import numpy as np

from . import blowup, superquadrics
from .contact_laws import effective_youngs_modulus
from .errors import RunFailure
from .quantities import OVERLAP_WARN_RATIO
from .walls import overlap_ratios, surface_speeds


def critical_timestep(sim):
    """(Rayleigh time, Hertz time) in s after LIGGGHTS ``fix_check_timestep_gran`` (physics.md, seed 000).

    t_R = min_i pi r sqrt(rho/G) / (0.1631 nu + 0.8766), G = Y / (2 (1+nu));
    t_H = min_i 2.87 (m^2 / (R Y*^2 v))^(1/5) with m the particle mass, R = r/2, Y* the largest over the
    types it can touch (particle types present and wall types), v = max(2 v_max, v_max + v_wall_max) with
    the fastest wall surface (engine.walls.surface_speeds); infinite when v = 0. LIGGGHTS 3.8 takes Y* of the particle's own type
    pair only and no primitive wall's speed: README.md says why we keep the smaller, safer bound.
    Vectorised over particles (per-type lookup tables): cheap enough to re-check during a run.
    """
    s = sim.state
    if sim.n == 0:
        return superquadrics.critical_times(sim)
    ntypes = max(sim.materials)
    table = np.full((ntypes + 1, 3), np.nan)
    for t, (y_t, nu_t, rho_t) in sim.materials.items():
        table[t] = (y_t, nu_t, rho_t)
    user_types = s.ptype + 1
    y, nu, rho = table[user_types, 0], table[user_types, 1], table[user_types, 2]
    shear = y / (2.0 * (1.0 + nu))
    t_r = float(np.min(math.pi * s.radius * np.sqrt(rho / shear) / (0.1631 * nu + 0.8766)))
    v_max = float(np.sqrt(np.max(np.einsum("ij,ij->i", s.v, s.v))))
    v_wall = max(surface_speeds(sim), default=0.0)
    v = max(2.0 * v_max, v_max + v_wall)
    if v == 0.0:
        return t_r, math.inf
    present = np.nonzero(np.bincount(user_types, minlength=ntypes + 1))[0].tolist()
    partners = sorted(set(present) | {w["type"] for w in sim.walls})
    ystar = np.full(ntypes + 1, np.nan)
    for t in present:
        ystar[t] = max(effective_youngs_modulus(*sim.materials[t][:2], *sim.materials[p][:2])
                       for p in partners)
    ystar_i = ystar[user_types]
    t_h = float(np.min(2.87 * (s.mass * s.mass / (0.5 * s.radius * ystar_i * ystar_i * v)) ** 0.2))
    return t_r, t_h


def check_timestep(sim, where: str):
    """The check at run start: logs both times and the ratios; warns (strict: fails) above the fraction."""
    t_r, t_h = critical_timestep(sim)
    sim.log.info(f"critical time step: Rayleigh time {t_r:.6g} s (dt/t_R = {sim.dt / t_r:.4g}), "
                 f"Hertz time {t_h:.6g} s (dt/t_H = {sim.dt / t_h:.4g}), fraction limit "
                 f"{sim.timestep_fraction:g}")
    _timestep_verdicts(sim, where, "", t_r, t_h, warned=set())


def recheck_timestep(sim, where: str, warned: set):
    """The re-check every `timestep_every` steps with the current speeds; each kind of warning once per run
    (warned holds the kinds already given)."""
    t_r, t_h = critical_timestep(sim)
    _timestep_verdicts(sim, where, f"step {sim.step}: ", t_r, t_h, warned)


def _timestep_verdicts(sim, where: str, prefix: str, t_r: float, t_h: float, warned: set):
    blowup.check_timestep(sim, t_r, t_h, where)
    for label, t_c in (("Rayleigh", t_r), ("Hertz", t_h)):
        if sim.dt > sim.timestep_fraction * t_c and label not in warned:
            text = (f"{prefix}time step {sim.dt:g} s is {sim.dt / t_c:.3g} of the {label} time {t_c:.4g} s, "
                    f"above the allowed fraction {sim.timestep_fraction:g}")
            if sim.timestep_strict:
                raise RunFailure(f"{where}: {text} (strict time step check)")
            warned.add(label)
            sim.log.warning(text)
    s = sim.state
    if sim.n and "skin" not in warned:
        v_max = float(np.sqrt(np.max(np.einsum("ij,ij->i", s.v, s.v))))
        if 2.0 * v_max * sim.dt > sim.skin:
            warned.add("skin")
            sim.log.warning(f"{prefix}relative velocity {2 * v_max:.4g} m/s times dt exceeds the neighbor "
                            f"skin {sim.skin:g} m; contacts may be missed")


def wall_overlaps(sim):
    """(particle-wall contacts above 10 % of the radius, largest overlap / radius) over all walls, vectorised.

    The overlaps of engine.walls.overlap_ratios (planes, cylinders, meshes).
    """
    if not sim.walls or sim.n == 0:
        return 0, 0.0
    ratio = overlap_ratios(sim)
    return int(np.count_nonzero(ratio > OVERLAP_WARN_RATIO)), max(0.0, float(ratio.max()))


def check_finite(sim, where):
    """Positions, velocities, forces, spins and the kinetic energies they give must be finite doubles: a
    speed of 1e200 m/s is finite, its 0.5 m v^2 is not, and thermo would print inf."""
    s = sim.state
    with np.errstate(all="ignore"):
        kinetic = 0.5 * s.mass * np.einsum("ij,ij->i", s.v, s.v)
        rotational = 0.2 * s.mass * s.radius ** 2 * np.einsum("ij,ij->i", s.omega, s.omega)
    for label, array in (("velocity", s.v), ("force", s.f), ("angular velocity", s.omega),
                         ("position", s.x), ("kinetic energy", kinetic), ("rotational energy", rotational)):
        finite = np.isfinite(array) if array.ndim == 1 else np.all(np.isfinite(array), axis=1)
        bad = np.nonzero(~finite)[0]
        if len(bad):
            raise RunFailure(f"{where}: non-finite {label} of particle {int(s.pid[bad[0]])} at step "
                             f"{sim.step}")


def check_superquadrics(sim, where):
    """Superquadrics: finite positions, velocities and angular momenta; no body with more contacts than its
    history slots (engine/superquadrics.py SLOTS)."""
    sq = sim.superquadrics
    for label, array in (("position", sq.x), ("velocity", sq.v), ("angular momentum", sq.angmom)):
        bad = np.nonzero(~np.all(np.isfinite(array), axis=1))[0]
        if len(bad):
            raise RunFailure(f"{where}: non-finite {label} of superquadric {int(sq.sid[bad[0]])} at step {sim.step}")
    if sq.status[0]:
        raise RunFailure(f"{where}: a superquadric had more than {superquadrics.SLOTS} contacts with bodies of "
                         f"higher id by step {sim.step} (its contact history slots)")


def report_lost(sim, lost, where: str, started_with: int):
    """Warn with count and ids; a run that started with particles and has none left fails (LIGGGHTS
    stops with "Lost atoms" by default): an empty simulation is broken physics, not a result."""
    lost_ids, lost_steps, nlost = lost.ids, lost.steps, int(lost.count[0])
    if nlost:
        ids = ", ".join(str(i) for i in lost_ids[:nlost][:20]) + (" ..." if nlost > 20 else "")
        sim.log.warning(f"{nlost} particle(s) left the fixed domain and were removed (ids {ids}; first at "
                        f"step {int(lost_steps[0])})")
        sim.lost_total += nlost
        if started_with and sim.n == 0:
            raise RunFailure(f"{where}: all {started_with} particles present at the start of the run left the "
                             f"fixed domain (the last at step {int(lost_steps[nlost - 1])}); nothing is left "
                             "to simulate")
