"""The blow-up rule: a run that has clearly blown up stops with exit code 1 by default.

Finite values and kept particles are not enough: a gas of 500 spheres at 1.5 or 5 times the critical time
step stays finite while its overlaps pass the radius and its kinetic energy grows 1e4 times. Two limits,
checked where the compiled loop already hands back to Python (every output or time-step re-check stop and
the end of a run; never inside the step loop). The overlap limit is on by default; the time-step limit is
for a run that wants it:

- **Overlap.** The largest particle-particle overlap may not exceed ``max_overlap`` (default 0.5) of the
  smaller radius. Hertz and Hooke contacts are models of small overlaps (Hertz: d << R; physics.md); at half a
  radius two equal spheres' centres are 1.5 r apart and the contact force is an artefact of the time step.
  A sound run stays below: the collection's runs keep below 10 %, the scenes of testcases/scenes below 30 %,
  a soft (Y = 1e7 Pa) gas at 0.2 of the critical time step reaches 21 % (tests/reliability/test_engine_verdicts.py and test_blowup.py measure these).
- **Time step** (off unless set). The time step may not exceed ``timestep_factor`` times the critical time
  step min(Rayleigh time, Hertz time) of engine.guards.critical_timestep, at the run start or any re-check;
  ``timestep_factor`` 1 is five times the fraction 0.2 that only warns: at dt >= t_c a contact lasts about one
  step or less, and no integrator resolves it (LIGGGHTS' fix check/timestep/gran warns from the user's
  fraction on). It is not a default because it also stops runs where nothing touches.

``set blowup`` (``max_overlap``, ``timestep_factor``, ``enabled``) changes the limits for a hard case; the
environment variables ``DEM_BLOWUP_MAX_OVERLAP`` and ``DEM_BLOWUP_TIMESTEP_FACTOR`` (``off`` disables one)
give the defaults of a run - the harness sets them from a run.config's ``stability.blowup``.
"""
from __future__ import annotations

import math
import os

from .errors import InputError, RunFailure

DEFAULT_MAX_OVERLAP = 0.5
#: off by default: a time step above the Rayleigh time is harmless where nothing touches (a free fall is exact
#: at any dt: testcases/analytic/free_fall), so only the overlap says a run has blown up
DEFAULT_TIMESTEP_FACTOR = math.inf


def _from_environment(name: str, default: float) -> float:
    """A limit from the environment: a positive number, or ``off`` (no limit: infinity)."""
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    if text.lower() in ("off", "false", "none"):
        return math.inf
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0.0):
        raise InputError(f"environment variable {name}: must be a positive number or 'off', got {text[:40]!r}")
    return value


def default_limits() -> tuple[float, float]:
    """(max overlap / smaller radius, time step / critical time step) of a new simulation."""
    return (_from_environment("DEM_BLOWUP_MAX_OVERLAP", DEFAULT_MAX_OVERLAP),
            _from_environment("DEM_BLOWUP_TIMESTEP_FACTOR", DEFAULT_TIMESTEP_FACTOR))


def check_overlap(sim, worst: float, where: str) -> None:
    """Stop the run when the largest overlap / smaller radius (``worst``, at ``sim.step``) is above the limit."""
    if worst > sim.blowup_overlap:
        raise RunFailure(f"{where}: blow-up at step {sim.step}: a contact overlaps {worst:.1%} of the smaller "
                         f"radius, above the limit {sim.blowup_overlap:.0%} (engine/README.md, 'Blow-up'; a "
                         "time step too large for the contact stiffness; 'set blowup' relaxes it for a hard case)")


def check_timestep(sim, t_r: float, t_h: float, where: str) -> None:
    """Stop the run when dt is above ``timestep_factor`` times min(t_R, t_H) (s)."""
    t_c = min(t_r, t_h)
    if sim.dt > sim.blowup_timestep * t_c:
        label = "Rayleigh" if t_r <= t_h else "Hertz"
        raise RunFailure(f"{where}: blow-up at step {sim.step}: time step {sim.dt:g} s is {sim.dt / t_c:.3g} "
                         f"times the critical ({label}) time step {t_c:.4g} s, above the limit "
                         f"{sim.blowup_timestep:g} (engine/README.md, 'Blow-up'; 'set blowup' relaxes it)")
