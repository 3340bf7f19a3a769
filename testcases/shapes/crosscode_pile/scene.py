# Cross-code settling pile (YADE side; scene.json and in.scene are the same scene for the bundled engine and
# LIGGGHTS): 200 dumbbells (two touching spheres, r = 1.5 mm, density 2500; O.bodies.appendClumped, whose
# mass and inertia are exact for spheres that do not overlap) at random positions and orientations fall into a
# 30 x 30 mm box of plane walls. Positions: centres uniform in the engine's region shrunk by the bounding radius
# (3 mm, as in.scene's), a candidate kept when its bounding sphere overlaps no other (the engine's
# clump_packing does the same); axes uniform on the unit sphere; Python's random seeded with ${seed}.
# Hertz-Mindlin with LIGGGHTS' damping (betan = betas = sqrt(5/6) |beta(e)|, ../../crosscode/hertz_head_on/
# scene.py; in.scene keeps LIGGGHTS' default tangential damping), Y = 5e6 Pa, nu = 0.45, e = 0.5, mu = 0.5, the
# walls fixed spheres of radius 1 km touching the planes (../../crosscode/lattice_box/scene.py), no numerical
# damping, dt = 1e-5 s. Thermo com_z: the bodies' centre of mass (m).
import math
import random
import yade_series as series

v = series.variables(seed=1, steps=50000, thermo_every=1000)
e = 0.5
beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
damping = math.sqrt(5.0 / 6.0) * abs(beta)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.5)))
big = 1000.0
for center in ((0, 0, -big), (-0.015 - big, 0, 0), (0.015 + big, 0, 0), (0, -0.015 - big, 0), (0, 0.015 + big, 0)):
    O.bodies.append(sphere(center, big, material=material, fixed=True))

r, bounding = 0.0015, 0.003
lo, hi = (-0.012, -0.012, 0.003), (0.012, 0.012, 0.117)
stream = random.Random(v["seed"])
centres = []
while len(centres) < 200:
    c = [stream.uniform(lo[k], hi[k]) for k in range(3)]
    if all((c[0] - d[0]) ** 2 + (c[1] - d[1]) ** 2 + (c[2] - d[2]) ** 2 >= (2 * bounding) ** 2 for d in centres):
        centres.append(c)
for c in centres:
    # a uniformly random axis: z uniform in [-1, 1] and a uniform azimuth (Archimedes' hat-box theorem)
    z, phi = stream.uniform(-1.0, 1.0), stream.uniform(0.0, 2.0 * math.pi)
    s = math.sqrt(1.0 - z * z)
    axis = (s * math.cos(phi), s * math.sin(phi), z)
    O.bodies.appendClumped([sphere(tuple(c[k] - r * axis[k] for k in range(3)), r, material=material),
                            sphere(tuple(c[k] + r * axis[k] for k in range(3)), r, material=material)])


def com_z():
    """Centre of mass height of the bodies (m)."""
    mass = moment = 0.0
    for body in series.bodies(O):
        mass += body.state.mass
        moment += body.state.mass * body.state.pos[2]
    return moment / mass


thermo = series.Thermo(every=v["thermo_every"], extra={"com_z": com_z})
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=damping, betas=damping)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
