"""The series a YADE script writes for the harness, the same files the bundled engine writes.

    import yade_series as series

    v = series.variables(steps=1000, thermo_every=10)    # NAME=VALUE script arguments, typed like the defaults
    thermo = series.Thermo(every=v["thermo_every"])        # thermo.csv: step,time,atoms,ke,rke
    O.engines = [ForceResetter(), InsertionSortCollider([...]), InteractionLoop([...], [...], [...]),
                 thermo.engine(),                          # between the forces and the integrator
                 NewtonIntegrator(damping=0, gravity=(0, 0, -9.81))]
    series.run(v["steps"], thermo)                         # steps 0..steps sampled; timing.json written

Files (in the working directory, the harness' run folder):

``thermo.csv``
    ``step,time,atoms,ke,rke`` (+ columns of ``Thermo(extra={name: function})``), a row every ``every``
    iterations from step 0. atoms = dynamic spheres, free or members of a clump; ke and rke are summed over
    the bodies, each free sphere and each clump once (its members are not bodies of their own, as in the
    bundled engine and LIGGGHTS' ke/multisphere): ke = sum 1/2 m |v|^2 (J); rke = sum 1/2 I_k w_k^2 (J,
    principal inertia ``state.inertia``; 2/5 m r^2 for a sphere) = 1/2 L.w for a clump.
``timing.json``
    seconds: ``total`` (wall time of the iterations), and with ``O.timingEnabled`` (the default of ``run``)
    the engines' ``execTime`` summed as pair (InteractionLoop), neigh (collider), modify (NewtonIntegrator),
    output (PyRunner, VTKRecorder), other (everything else).

Velocities at full steps. YADE's NewtonIntegrator is a leap-frog: a body's ``state.vel`` is v(t - dt/2)
while the forces F(t) of the positions x(t) are computed (YADE docs, "Motion integration"). The sampler runs
after InteractionLoop and before NewtonIntegrator and reports the velocity-Verlet full-step value the codes
it is compared with print, v(t) = v(t - dt/2) + dt/2 (F(t)/m + g), w(t) = w(t - dt/2) + dt/2 T(t)/I, at step
``O.iter`` (t = O.iter dt). A clump's force and torque are its members' summed onto its centre of mass (what
NewtonIntegrator does before it moves the clump: F = sum f_i, T = sum t_i + (x_i - X) x f_i, plus what
acts on the clump body itself); an aspherical clump (unequal principal moments) is integrated through its
angular momentum ``state.angMom`` = L(t - dt/2), so L(t) = L(t - dt/2) + dt/2 T(t) and w(t) = R I^-1 R^T L(t)
with R the rotation of ``state.ori`` (NewtonIntegrator recomputes such a clump's ``angVel`` from ``angMom``:
a script spins it by setting ``angMom``). With NewtonIntegrator.damping != 0 this shift leaves YADE's damping out.
Because the sample of step N is taken inside iteration N + 1, ``run(N)`` runs N + 1 iterations (the last
one's integration is not sampled).
"""
import json
import math
import sys
import time

__all__ = ["variables", "Thermo", "run", "write_timing", "start_at_full_step", "write_final_state", "bodies",
           "count_spheres", "body_force"]

_SAMPLERS = {}


def variables(**defaults):
    """Script arguments ``NAME=VALUE`` (the harness passes a run.config's ``variables`` so) over ``defaults``.

    A value is converted to the type of its default (int, float, bool: 1/true/yes, str); a value that does not
    convert stops the script with an error naming it. Names without a default are left out: a cross-code
    run.config gives one set of variables to every code, each script takes the ones it knows.
    """
    values = dict(defaults)
    for word in sys.argv[1:]:
        if "=" not in word:
            continue
        name, value = word.split("=", 1)
        if name not in defaults:
            continue
        default = defaults[name]
        try:
            if isinstance(default, bool):
                values[name] = value.strip().lower() in ("1", "true", "yes")
            elif isinstance(default, int):
                values[name] = int(float(value)) if float(value).is_integer() else int(value)
            elif isinstance(default, float):
                values[name] = float(value)
            else:
                values[name] = value
        except ValueError:
            raise SystemExit(f"variable {name}={value!r}: not a {type(default).__name__}") from None
    return values


class Thermo:
    """Thermo rows every ``every`` iterations into ``file`` (``thermo.csv``), sampled by ``engine()``."""

    def __init__(self, every=100, file="thermo.csv", extra=None):
        if int(every) < 1:
            raise SystemExit(f"Thermo(every={every}): must be at least 1")
        self.every = int(every)
        self.file = file
        self.extra = dict(extra or {})
        self.handle = open(file, "w", encoding="utf-8")
        self.handle.write(",".join(["step", "time", "atoms", "ke", "rke", *self.extra]) + "\n")
        self.last_step = None
        self.key = f"_yade_series_sampler_{id(self)}"
        self.limit = None

    def engine(self):
        """A PyRunner that samples each ``every`` iterations; put it after InteractionLoop, before Newton."""
        # YADE's modules exist only inside a YADE process (and the script's own __main__)
        from yade.wrapper import PyRunner
        import __main__

        __main__.__dict__[self.key] = self
        return PyRunner(command=f"{self.key}.sample()", iterPeriod=self.every, initRun=True, label=self.key)

    def sample(self):
        """Write the row of step ``O.iter`` (see the module docstring for the full-step velocities)."""
        # YADE's modules exist only inside a YADE process (and the script's own __main__)
        from yade.wrapper import Omega, NewtonIntegrator

        O = Omega()
        step = O.iter
        if step == self.last_step or (self.limit is not None and step > self.limit):
            return
        dt = O.dt
        gravity = (0.0, 0.0, 0.0)
        for engine in O.engines:
            if isinstance(engine, NewtonIntegrator):
                gravity = tuple(engine.gravity)
        atoms, ke, rke = count_spheres(O), 0.0, 0.0
        for body in bodies(O):
            state = body.state
            m = state.mass
            force, torque = body_force(O, body)
            inertia = state.inertia
            v = [state.vel[k] + 0.5 * dt * (force[k] / m + gravity[k]) for k in range(3)]
            ke += 0.5 * m * (v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
            if body.isClump and max(inertia) > min(inertia):
                # YADE's exactAsphericalRot: the angular momentum is the leap-frog's variable
                momentum = [state.angMom[k] + 0.5 * dt * torque[k] for k in range(3)]
                rke += 0.5 * _dot(momentum, _angular_velocity(state.ori, inertia, momentum))
                continue
            w = [state.angVel[k] + 0.5 * dt * torque[k] / inertia[k] if inertia[k] > 0 else state.angVel[k]
                 for k in range(3)]
            rke += 0.5 * (inertia[0] * w[0] ** 2 + inertia[1] * w[1] ** 2 + inertia[2] * w[2] ** 2)
        row = [step, step * dt, atoms, ke, rke] + [function() for function in self.extra.values()]
        self.handle.write(",".join(repr(float(x)) if isinstance(x, float) else str(x) for x in row) + "\n")
        self.last_step = step

    def close(self):
        self.handle.flush()
        self.handle.close()


def bodies(O):
    """The dynamic bodies: free spheres and clumps (a clump once, its members not)."""
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.wrapper import Sphere

    for body in O.bodies:
        if body is None or not body.dynamic or body.isClumpMember:
            continue
        if body.isClump or isinstance(body.shape, Sphere):
            yield body


def count_spheres(O):
    """Dynamic spheres, free or members of a clump (the particles the other codes count as atoms)."""
    from yade.wrapper import Sphere

    return sum(1 for body in O.bodies
               if body is not None and isinstance(body.shape, Sphere)
               and (body.dynamic or (body.isClumpMember and O.bodies[body.clumpId].dynamic)))


def body_force(O, body):
    """(force, torque) on a body at this step, as lists (N, N m): a clump's own plus its members' summed onto
    its centre of mass, T = sum t_i + (x_i - X) x f_i (YADE's Clump::addForceTorqueFromMembers)."""
    # sync=True: with several OpenMP threads the per-thread forces are summed only before NewtonIntegrator
    force, torque = list(O.forces.f(body.id, True)), list(O.forces.t(body.id, True))
    if body.isClump:
        centre = body.state.pos
        for member in body.shape.members:
            f, t = O.forces.f(member, True), O.forces.t(member, True)
            arm = O.bodies[member].state.pos - centre
            moment = arm.cross(f)
            for k in range(3):
                force[k] += f[k]
                torque[k] += t[k] + moment[k]
    return force, torque


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _angular_velocity(orientation, inertia, momentum):
    """w = R I^-1 R^T L (rad/s, space frame) for the principal moments ``inertia`` of the body frame that the
    quaternion ``orientation`` turns into the space frame, and the angular momentum L (space frame)."""
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.minieigenHP import Vector3

    body_frame = orientation.conjugate().Rotate(Vector3(*momentum))
    local = Vector3(*[body_frame[k] / inertia[k] if inertia[k] > 0 else 0.0 for k in range(3)])
    return list(orientation.Rotate(local))


def start_at_full_step():
    """Make the initial velocities full-step values, as velocity-Verlet codes read them.

    YADE's leap-frog reads ``state.vel`` at iteration 0 as v(-dt/2); a scene that sets v(0) = v0 (as LAMMPS,
    LIGGGHTS and the bundled engine do) calls this once, after ``O.dt``, the bodies and NewtonIntegrator are
    set and while no body touches another: v(-dt/2) = v0 - dt/2 g. Then free flight is the same in all codes
    to round-off (x(dt) = x0 + v0 dt + g dt^2/2).
    """
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.wrapper import Omega, NewtonIntegrator

    O = Omega()
    gravity = next((tuple(e.gravity) for e in O.engines if isinstance(e, NewtonIntegrator)), (0.0, 0.0, 0.0))
    for body in O.bodies:
        if body is not None and body.dynamic:
            body.state.vel = body.state.vel - 0.5 * O.dt * type(body.state.vel)(*gravity)


def write_final_state(file="thermo.csv"):
    """One thermo row of the state the simulation ended in (for a script that does not use Thermo).

    The launcher writes it when a script that finished without error left no thermo file, so that YADE's
    own examples, unchanged, still give the harness a result to compare between versions. Velocities are as
    YADE holds them (leap-frog: v(t - dt/2) after the last step); the row says so in column ``source``.
    """
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.wrapper import Omega

    O = Omega()
    atoms, ke, rke = count_spheres(O), 0.0, 0.0
    for body in bodies(O):
        state = body.state
        ke += 0.5 * state.mass * state.vel.squaredNorm()
        if body.isClump and max(state.inertia) > min(state.inertia):
            momentum = list(state.angMom)
            rke += 0.5 * _dot(momentum, _angular_velocity(state.ori, state.inertia, momentum))
        else:
            rke += 0.5 * sum(state.inertia[k] * state.angVel[k] ** 2 for k in range(3))
    with open(file, "w", encoding="utf-8") as handle:
        handle.write("step,time,atoms,ke,rke,source\n")
        handle.write(f"{O.iter},{float(O.time)!r},{atoms},{float(ke)!r},{float(rke)!r},final_state\n")


def write_timing(total, file="timing.json"):
    """timing.json with ``total`` (s) and, with O.timingEnabled, the engines' execTime (ns) per section."""
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.wrapper import Omega

    O = Omega()
    timing = {"total": float(total), "pair": 0.0, "neigh": 0.0, "comm": 0.0, "modify": 0.0, "output": 0.0,
              "other": 0.0}
    if O.timingEnabled:
        for engine in O.engines:
            kind = type(engine).__name__
            seconds = engine.execTime * 1e-9
            if kind == "InteractionLoop":
                timing["pair"] += seconds
            elif "Collider" in kind:
                timing["neigh"] += seconds
            elif kind == "NewtonIntegrator":
                timing["modify"] += seconds
            elif kind in ("PyRunner", "VTKRecorder"):
                timing["output"] += seconds
            else:
                timing["other"] += seconds
    timing = {key: value for key, value in timing.items() if math.isfinite(value)}
    with open(file, "w", encoding="utf-8") as handle:
        json.dump(timing, handle)
    return timing


def run(steps, thermo=None, timing=True):
    """Run ``steps`` iterations (plus the one that samples step ``steps``, see the module docstring) and write
    timing.json; ``thermo`` (a Thermo) gets its last row and is closed."""
    # YADE's modules exist only inside a YADE process (and the script's own __main__)
    from yade.wrapper import Omega

    O = Omega()
    O.timingEnabled = bool(timing)
    iterations = int(steps) + (1 if thermo is not None else 0)
    if thermo is not None:
        thermo.limit = O.iter + int(steps)
    start = time.perf_counter()
    O.run(iterations, True)
    total = time.perf_counter() - start
    if thermo is not None:
        thermo.close()
    return write_timing(total)
