# Cross-code dumbbell (YADE side; scene.json and in.scene are the same scene for the bundled engine and
# LIGGGHTS): two touching spheres (r = 5 mm, density 2500) as one clump (O.bodies.appendClumped: mass and
# inertia of the union, exact here as the spheres do not overlap), dropped flat on a plane at 1 m/s, no
# gravity. YADE's Hertz-Mindlin law with LIGGGHTS' normal damping (betan = sqrt(5/6) |beta(e)|,
# ../../crosscode/hertz_head_on/scene.py), no friction, Y = 1e7 Pa, nu = 0.3, dt = 2e-7 s. The plane is the top
# of a fixed sphere of radius 1 km (a YADE Wall would get R* = r/2: ../../crosscode/oblique_wall_spin/scene.py).
# YADE damps each member's contact with the member's own mass (docs/shapes.md), so for e < 1 the clump leaves
# as fast as one of its spheres would alone, faster than in the engine and LIGGGHTS.
import math
import yade_series as series

v = series.variables(e=0.5, steps=20000, thermo_every=500)
e = v["e"]
beta = 0.0 if e >= 1 else math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=1e7, poisson=0.3, density=2500, frictionAngle=0.0))
O.bodies.append(sphere((0, 0, -1000.0), 1000.0, material=material, fixed=True))
clump, members = O.bodies.appendClumped([sphere((-0.005, 0, 0.006), 0.005, material=material),
                                         sphere((0.005, 0, 0.006), 0.005, material=material)])
O.bodies[clump].state.vel = (0, 0, -1.0)
thermo = series.Thermo(every=v["thermo_every"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=math.sqrt(5.0 / 6.0) * abs(beta), betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, 0)),
]
O.dt = 2e-7
series.start_at_full_step()
series.run(v["steps"], thermo)
