# Cross-code scene lattice_box (YADE side; in.liggghts, in.lammps and scene.json are the same scene).
# 64 spheres on a 4 mm lattice fall into a 20 x 20 mm box of five plane walls (in.liggghts). Hertz-Mindlin
# with LIGGGHTS' normal damping (betan = sqrt(5/6) |beta(e)|), no tangential damping (betas = 0); the walls
# are fixed spheres of radius 1 km touching the planes (../oblique_wall_spin/scene.py: a YADE Wall would get
# R* = r/2), NewtonIntegrator without numerical damping.
import math
import yade_series as series

v = series.variables(steps=5000, thermo_every=50)
e = 0.5
beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
big = 1000.0
for center in ((0, 0, -big), (-0.01 - big, 0, 0), (0.01 + big, 0, 0), (0, -0.01 - big, 0), (0, 0.01 + big, 0)):
    O.bodies.append(sphere(center, big, material=material, fixed=True))
for x in (-0.006, -0.002, 0.002, 0.006):
    for y in (-0.006, -0.002, 0.002, 0.006):
        for z in (0.002, 0.006, 0.010, 0.014):
            body = O.bodies[O.bodies.append(sphere((x, y, z), 0.0015, material=material))]
            body.state.vel = (0.3, 0.1, 0.0)
thermo = series.Thermo(every=v["thermo_every"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=math.sqrt(5.0 / 6.0) * abs(beta), betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
