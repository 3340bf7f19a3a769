"""The run loop: the `run` command around the compiled kernel.

Between two steps at which Python must look at the state (an output, a time step re-check, the end of the
run) the whole step loop runs inside compiled code (`engine.kernels`); Python only decides where the next stop
is, checks the guards (`engine.guards`) and writes the output (`engine.output`).
"""
from __future__ import annotations

import time
import numpy as np

from . import blowup, guards, modifiers, quantities, superquadrics
from . import threads as thread_pool
from . import state as particle_state
from .errors import RunFailure
from .kernels import Combination, Constants, build_kernel, parameter_table
from .models import SUBMODELS, options
from .neighbor import empty_list, lost_record, stale_band
from .quantities import OVERLAP_WARN_RATIO
from .script import Fields
from .mesh import empty_mesh_list, mesh_rebuild
from .walls import dense_count, features as wall_features, surface_speeds, wall_set

#: m/s, the largest wall surface speed a run accepts: the speed of light (1e200 m/s is finite, but the
#: products of such a speed are not)
MAX_WALL_SPEED = 299_792_458.0


def combination(sim, parallel: bool = False) -> Combination:
    """The compiled code this scene needs: its submodels and their options, wall shapes, gravity and periodic
    axes, and whether its loops are compiled for several threads."""
    model = {name: sim.model[name] for name in (*SUBMODELS, *options())}
    return Combination(parallel=parallel, **model, **wall_features(sim.walls),
                       gravity=any(mod.acceleration() is not None for mod in sim.active_modifiers()),
                       periodic=tuple(bool(p) for p in sim.periodic),
                       clumps=sim.bodies is not None, superquadrics=sim.superquadrics is not None)


def steps_of(fields: Fields) -> int:
    return int(fields.data.get("steps") or 0)


def check_ready(sim, fields: Fields):
    """Everything a run needs is there: domain, time step, contact model, interactions, the walls that
    quantities name, periodic lengths of at least twice the cutoff."""
    if sim.lo is None:
        raise fields.error("steps", "cannot run: no domain (create a domain first)")
    if sim.dt is None:
        raise fields.error("steps", "cannot run: no time step (set property timestep first)")
    if sim.model is None:
        raise fields.error("steps", "cannot run: no contact model (create a contact_model first)")
    problem = superquadrics.problem(sim)
    if problem:
        raise fields.error("steps", f"cannot run: {problem}")
    used = sorted(set((sim.state.ptype + 1).tolist()) | {w["type"] for w in sim.walls}
                  | set((sim.superquadrics.ptype + 1).tolist() if sim.superquadrics is not None else [])
                  | {t for mod in sim.active_modifiers() for t in mod.particle_types()})
    for a in used:
        for b in used:
            if a <= b and (a, b) not in sim.interactions:
                raise fields.error("steps", f"cannot run: no interaction for material types {a} and {b} "
                                   "(create an interaction)")
    names = {w["name"] for w in sim.walls}
    requested = list(sim.output.thermo_columns) + [q for mod in sim.active_modifiers() for q in mod.quantities()]
    for q, wall in quantities.wall_names(requested):
        if wall not in names:
            raise fields.error("steps", f"cannot run: quantity '{q}' names no wall '{wall}' "
                               f"(walls: {', '.join(sorted(names)) or 'none'})")
    for q in requested:
        problem = quantities.unknown_reference(sim, q)
        if problem:
            raise fields.error("steps", f"cannot run: quantity '{q}' {problem}")
    end_time = sim.time + steps_of(fields) * sim.dt
    if end_time + sim.dt == end_time:
        raise fields.error("steps", f"cannot run: the time step {sim.dt:g} s is below the resolution of the simulated "
                           f"time {end_time:g} s (adding it changes nothing)")
    for w, speed in zip(sim.walls, surface_speeds(sim)):
        if not speed <= MAX_WALL_SPEED:
            raise fields.error("steps", f"cannot run: wall '{w['name']}' moves its surface at {speed:g} m/s, "
                               f"faster than light ({MAX_WALL_SPEED:g} m/s; its 'velocity' or angular velocity)")
    inserting = any(mod.kind == "insert" for mod in sim.active_modifiers())
    for q in requested:
        m = quantities.PARTICLE_QUANTITY.match(q)
        if m and not inserting and int(m.group(2)) >= sim.next_id:
            # ids are given in creation order from 1 and never reused: without an inserter it can never exist
            raise fields.error("steps", f"cannot run: quantity '{q}' names particle {m.group(2)}, which does not "
                               f"exist (ids so far: " + (f"1 ... {sim.next_id - 1}" if sim.next_id > 1 else "none")
                               + "; no insert modifier is fixed)")
    if sim.n == 0 and not inserting and not superquadrics.count(sim):
        for q in requested:
            if q.startswith("com_"):
                raise fields.error("steps", f"cannot run: quantity '{q}' has no value without particles "
                                   "(create particles or fix an insert modifier first)")
    for mod in sim.active_modifiers():
        problem = mod.problem(sim)
        if problem:
            raise fields.error("steps", f"cannot run: modifier '{mod.name}' {problem}")
    if sim.n:
        cutoff = 2 * float(sim.state.radius.max()) + sim.skin
        for a in range(3):
            if sim.periodic[a] and sim.hi[a] - sim.lo[a] < 2 * cutoff:
                raise fields.error("steps", f"cannot run: periodic length along {'xyz'[a]} must be at least "
                                   f"twice the neighbor cutoff ({2 * cutoff:g} m)")
    # a clump's lever arms are nearest images (engine/clumps.py, body_pass): its members within half a period
    reach = max((t.bounding_radius for t in sim.clump_templates.values()), default=0.0)
    for a in range(3):
        if sim.periodic[a] and reach and sim.hi[a] - sim.lo[a] <= 2 * reach:
            raise fields.error("steps", f"cannot run: periodic length along {'xyz'[a]} must be more than twice "
                               f"the largest clump template's bounding radius ({2 * reach:g} m)")


def fit_history(sim, combo: Combination):
    """History arrays sized for this combination: width 0 (nothing stored) unless a submodel needs it; the
    pairs' reaction rows as wide as the submodels that push or turn the partner."""
    width = combo.history_width
    nbr = sim.nbr
    if len(nbr.start) > sim.n + 1:  # stale list after particles vanished: start afresh
        nbr = empty_list(width, combo.reaction_width)
    if nbr.hist.shape != (len(nbr.j) if width else 0, width):
        nbr = nbr._replace(hist=np.zeros((len(nbr.j) if width else 0, width)))
    if nbr.reaction.shape != (len(nbr.j), combo.reaction_width):
        nbr = nbr._replace(reaction=np.zeros((len(nbr.j), combo.reaction_width)))
    if nbr.touch.shape != nbr.j.shape:
        nbr = nbr._replace(touch=np.zeros(len(nbr.j), dtype=np.uint8))
    if len(nbr.own) != len(nbr.start) - 1:
        nbr = nbr._replace(own=np.zeros(len(nbr.start) - 1, dtype=np.uint8))
    if len(nbr.band) != len(nbr.start) - 1:
        nbr = nbr._replace(**stale_band(len(nbr.start) - 1))
    if nbr.live.shape != nbr.j.shape:  # unknown: every pair's history is tested at its first evaluation
        nbr = nbr._replace(live=np.ones(len(nbr.j), dtype=np.uint8))
    sim.nbr = nbr
    if sim.mesh_nbr.hist.shape[1] != width:  # another contact model: mesh contacts start without history
        sim.mesh_nbr = empty_mesh_list(0, width)
    sim.state = particle_state.fit_wall_history(sim.state, dense_count(sim.walls), width)


def next_stop(sim, end: int) -> int:
    """The next step at which Python looks at the state: an output, a time step re-check, or the end."""
    stop = end
    for every in sim.output.every(sim.active_modifiers()) + ([sim.timestep_every] if sim.timestep_every else []):
        stop = min(stop, (sim.step // every + 1) * every)
    return stop


class _Kernel:
    """What a run computes with: the compiled module, its combination, the wall arrays, the pair parameter
    table and the constants."""

    def __init__(self, sim, threads: int):
        self.combo = combination(sim, parallel=threads > 1)
        self.module = build_kernel(self.combo)
        fit_history(sim, self.combo)
        self.pp = parameter_table(self.combo, sim.materials, sim.interactions, max(sim.materials))
        if sim.wall_force.shape[0] != len(sim.walls):
            sim.wall_force = np.zeros((len(sim.walls), 3))
            sim.wall_torque = np.zeros((len(sim.walls), 3))
        self.walls = wall_set(sim)
        if self.combo.superquadrics:
            superquadrics.fit_walls(sim)
            self.sq_laws = superquadrics.laws(sim)
        self.constants = Constants(dt=sim.dt, characteristic_velocity=sim.model["characteristic_velocity"],
                                   gravity=sim.gravity_vector(), lo=sim.lo, hi=sim.hi, periodic=sim.periodic,
                                   skin=sim.skin, history_transfer=np.array(self.combo.history_transfer(),
                                                                            dtype=np.float64))

    def bodies(self, sim) -> tuple:
        """The trailing arguments of the kernels of clump scenes: the bodies (engine/clumps.py), read from sim at
        each call (inserting clumps mid-run replaces the bodies' arrays); of superquadric scenes, the bodies and
        their contact laws (engine/superquadrics.py); none for a scene of spheres."""
        return (((sim.bodies,) if self.combo.clumps else ())
                + ((sim.superquadrics, self.sq_laws) if self.combo.superquadrics else ()))

    def setup(self, sim, lost):
        """Fresh neighbor lists and forces for sim's state (kernels.STEP_LOOP setup)."""
        return self.module.setup(sim.state, sim.n, sim.nbr, sim.mesh_nbr, self.walls, self.pp, self.constants,
                                 sim.step, lost, *self.bodies(sim))

    def steps(self, sim, nsteps: int, timers, lost):
        """nsteps compiled steps from sim's state (kernels.STEP_LOOP run_steps)."""
        return self.module.run_steps(sim.state, sim.n, sim.nbr, sim.mesh_nbr, self.walls, self.pp, self.constants,
                                     sim.step, nsteps, timers, lost, *self.bodies(sim))


def _prepare(sim, fields: Fields, threads: int) -> tuple:
    """The kernel compiled (or loaded) and the scene set up, outside the timed loop: fresh neighbor lists and
    forces if particles were added or changed. Returns (kernel, largest overlap ratio now)."""
    t0 = time.perf_counter()
    kernel = _Kernel(sim, threads)
    guards.check_timestep(sim, fields.where)
    if sim.dirty:
        lost = lost_record(sim.n)
        n, sim.nbr, sim.mesh_nbr = kernel.setup(sim, lost)
        sim.state = particle_state.trimmed(sim.state, n)
        guards.report_lost(sim, lost, fields.where, sim.n + int(lost.count[0]))
    # a zero-step call compiles run_steps (or loads it from the disk cache) outside the timed loop
    kernel.steps(sim, 0, np.zeros(3), lost_record(0))
    if kernel.combo.meshes:
        # the mesh contact list of the particles and mesh placement now (walls or particles may have changed
        # since the last run; the list only says which triangles are near, so building it anew changes no force)
        sim.mesh_nbr = mesh_rebuild(sim.state, sim.n, sim.mesh_nbr, kernel.walls.tri_v, sim.skin)
    # the overlap check between chunks is compiled too: not inside the timed loop
    _, n_large, worst = quantities.overlaps(sim)
    sim.timing["compile"] += time.perf_counter() - t0  # first call of a kernel compiles or loads it
    return kernel, n_large, worst


def _warn_start_overlaps(sim, n_large: int, worst: float):
    """Particles created (or restored) overlapping: the run would start with a violent push apart; say so as
    the run-time check does (that one only looks after the first chunk of steps)."""
    if n_large:
        sim.log.warning(f"step {sim.step}: {n_large} contact(s) overlap more than "
                        f"{OVERLAP_WARN_RATIO:.0%} of the smaller radius (max {worst:.1%}) at the start "
                        "of the run")
    n_wall, worst_wall = guards.wall_overlaps(sim)
    if n_wall:
        sim.log.warning(f"step {sim.step}: {n_wall} particle-wall contact(s) overlap more than "
                        f"{OVERLAP_WARN_RATIO:.0%} of the radius (max {worst_wall:.1%}) at the start of "
                        "the run")


class _Progress:
    """What the chunks of a run add up: timers [neigh, pair, modify] (s), particle-steps, rebuilds, the largest
    overlap ratio seen, whether the overlap warning and which time step warnings were given."""

    def __init__(self, worst: float):
        self.timers = np.zeros(3)
        self.particle_steps = 0
        self.rebuilds = 0
        self.max_overlap = worst
        self.overlap_warned = False
        self.timestep_warned: set = set()


def _chunk(sim, fields: Fields, kernel: _Kernel, progress: _Progress, stop: int, started_with: int,
           start_step: int, start_time: float):
    """The steps up to the next stop in compiled code, then the checks and modifiers of that stop."""
    n = sim.n
    lost = lost_record(n)
    status, bad, done, rebuilt, kept, sim.nbr, sim.mesh_nbr = kernel.steps(sim, stop - sim.step, progress.timers,
                                                                          lost)
    sim.state = particle_state.trimmed(sim.state, kept)
    progress.particle_steps += done * (n + superquadrics.count(sim))
    progress.rebuilds += rebuilt
    sim.step += done
    sim.time = start_time + (sim.step - start_step) * sim.dt
    if status == 1:
        sim.step += 1
        raise RunFailure(f"{fields.where}: non-finite position of particle {int(sim.state.pid[bad])} at "
                         f"step {sim.step}")
    guards.report_lost(sim, lost, fields.where, started_with)
    guards.check_finite(sim, fields.where)
    if kernel.combo.superquadrics:
        guards.check_superquadrics(sim, fields.where)
    _, n_large, worst = quantities.overlaps(sim)
    progress.max_overlap = max(progress.max_overlap, worst)
    if n_large and not progress.overlap_warned:
        progress.overlap_warned = True
        sim.log.warning(f"step {sim.step}: {n_large} contact(s) overlap more than "
                        f"{OVERLAP_WARN_RATIO:.0%} of the smaller radius (max {worst:.1%})")
    blowup.check_overlap(sim, worst, fields.where)
    if sim.timestep_every and sim.step % sim.timestep_every == 0:
        guards.recheck_timestep(sim, fields.where, progress.timestep_warned)
    modifiers.change_particles(sim)
    sim.output.write(sim, start=False)


def _report(sim, steps: int, threads: int, progress: _Progress, total: float, cpu: float):
    """The run's timing into sim.timing and its summary line into the log."""
    timers, particle_steps = progress.timers, progress.particle_steps
    t = sim.timing
    t["neigh"] += timers[0]
    t["pair"] += timers[1]
    t["modify"] += timers[2]
    t["total"] += total
    t["cpu"] += cpu
    t["steps"] += steps
    t["particles"] = sim.n + superquadrics.count(sim)
    t["particle_steps"] += particle_steps
    rate = particle_steps / total if total > 0 else 0.0
    sim.log.info(f"Loop time of {total:.6g} s for {steps} steps with {t['particles']} particles "
                 f"({rate:.4g} particle-steps/s); pair {timers[1]:.4g} s, neigh {timers[0]:.4g} s "
                 f"({progress.rebuilds} rebuilds), modify {timers[2]:.4g} s; max overlap "
                 f"{progress.max_overlap:.2%} of radius; particles lost so far {sim.lost_total}; cpu {cpu:.6g} s "
                 f"({particle_steps / cpu if cpu > 0 else 0.0:.4g} particle-steps per cpu second); "
                 f"threads {threads} ({thread_pool.layer()})")


def run(sim, fields: Fields):
    """The `run` command: `steps` time steps."""
    steps = fields.integer("steps", required=True, minimum=0)
    check_ready(sim, fields)
    # the thread count of the whole run, from the particles at its start: one thread compiles serial loops
    # (quicker to compile, no thread wake-ups); the bytes are the same either way
    threads = thread_pool.use(sim.n, sim.threads)
    started_with = sim.n
    created = sim.dirty
    kernel, n_large, worst = _prepare(sim, fields, threads)
    sim.dirty = False
    if created:
        _warn_start_overlaps(sim, n_large, worst)
    start_wall = time.perf_counter()
    start_cpu = time.process_time()  # CPU seconds too: on a shared machine wall time overstates the cost
    start_step, start_time = sim.step, sim.time
    progress = _Progress(worst)
    sim.output.where = fields.where
    # insert and outlet modifiers act before the output of their step (the thermo row counts what they did)
    modifiers.change_particles(sim)
    sim.output.write(sim, start=True)
    end = start_step + steps
    sim.output.end_step = end
    while sim.step < end:
        _chunk(sim, fields, kernel, progress, next_stop(sim, end), started_with, start_step, start_time)
    _report(sim, steps, threads, progress, time.perf_counter() - start_wall, time.process_time() - start_cpu)
