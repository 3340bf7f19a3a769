# Rotating drum of dumbbells (YADE side; clumps.json and in.clumps are the same scene for the bundled engine and
# LIGGGHTS): meshes/drum.stl as YADE facets (yade.ymport.stl) turned about +y at omega rad/s by a
# RotationEngine, ${count} dumbbells of two touching spheres (r = 2 mm, O.bodies.appendClumped) inserted at rest
# with random axes, up to 100 every 0.05 s (a PyRunner every 2500 steps: the target floor(2000 t) as the engine's
# insert modifier, what does not fit waits for the next insertion), centres uniform in in.clumps' region, a
# candidate kept when its bounding sphere (4 mm) overlaps no sphere there (the engine's rule); Python's random
# seeded with ${seed}. YADE's Hertz-Mindlin with LIGGGHTS' normal damping (betan = sqrt(5/6) |beta(e)|,
# ../../crosscode/hertz_head_on/scene.py), no tangential damping (in.clumps: tangential_damping off), no
# attractive normal force (YADE's never pulls, as limitForce on), Y = 5e6 Pa, nu = 0.45, e = 0.5, mu = 0.5,
# dt = 2e-5 s. A facet contact has R* = r/2 in this law (no radius of its own: ../../crosscode/
# oblique_wall_spin/scene.py), where the other codes take r for a wall. Thermo com_x, com_z: the bodies'
# centre of mass (m), from which angle.py takes the angle; VTKRecorder dumps of the member spheres.
import math
import random
import yade_series as series
from yade import ymport

v = series.variables(steps=250000, thermo_every=500, dump_every=5000, omega=2.0, count=288, seed=1)
e = 0.5
beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.5)))
drum = O.bodies.append(ymport.stl("meshes/drum.stl", material=material))

r, bounding = 0.002, 0.004
lo, hi = (-0.023, -0.005, -0.023), (0.023, 0.005, 0.023)
stream = random.Random(v["seed"])
inserted = [0, 0]   # dumbbells, insertions


def insert():
    """Insertion k (from 0) brings the total to floor(2000 (k + 1) 2500 dt), at most count; 200 candidates each."""
    target = min(v["count"], int(2000 * (inserted[1] + 1) * 2500 * O.dt + 1e-9))
    inserted[1] += 1
    near = [tuple(b.state.pos) for b in O.bodies if b is not None and b.isClumpMember
            and all(lo[k] - bounding - r <= b.state.pos[k] <= hi[k] + bounding + r for k in range(3))]
    while inserted[0] < target:
        for _ in range(200):
            c = [stream.uniform(lo[k], hi[k]) for k in range(3)]
            if all((c[0] - d[0]) ** 2 + (c[1] - d[1]) ** 2 + (c[2] - d[2]) ** 2 >= (bounding + r) ** 2 for d in near):
                break
        else:
            return
        z, phi = stream.uniform(-1.0, 1.0), stream.uniform(0.0, 2.0 * math.pi)
        s = math.sqrt(1.0 - z * z)
        axis = (s * math.cos(phi), s * math.sin(phi), z)
        members = [tuple(c[k] + sign * r * axis[k] for k in range(3)) for sign in (-1.0, 1.0)]
        O.bodies.appendClumped([sphere(m, r, material=material) for m in members])
        near += members
        inserted[0] += 1


def com(axis):
    """Centre of mass of the bodies along axis (m); 0 before the first insertion."""
    mass = moment = 0.0
    for body in series.bodies(O):
        mass += body.state.mass
        moment += body.state.mass * body.state.pos[axis]
    return moment / mass if mass > 0 else 0.0


thermo = series.Thermo(every=v["thermo_every"], extra={"com_x": lambda: com(0), "com_z": lambda: com(2)})
O.engines = [
    PyRunner(command="insert()", iterPeriod=2500, initRun=True),
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=math.sqrt(5.0 / 6.0) * abs(beta), betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    RotationEngine(ids=drum, rotationAxis=(0, 1, 0), rotateAroundZero=True, zeroPoint=(0, 0, 0),
                   angularVelocity=v["omega"]),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
    VTKRecorder(fileName="post/drum-", recorders=["spheres", "velocity", "mass"], iterPeriod=v["dump_every"],
                initRun=True),
]
O.dt = 2e-5
series.run(v["steps"], thermo)
