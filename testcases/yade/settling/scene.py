# 144 spheres (r = 1.5 mm) of a 6 x 6 x 4 lattice settle on a floor in YADE (Hertz-Mindlin with LIGGGHTS'
# normal damping for e = 0.5, friction 0.3, a floor of YADE's own Wall), 0.03 s; VTKRecorder writes the
# spheres every 1000 iterations (post/settling-spheres.ITER.vtu), which the harness reads as VTK dumps.
import math
import yade_series as series

v = series.variables(steps=3000, thermo_every=100)
e = 0.5
beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
O.bodies.append(utils.wall(0.0, axis=2, material=material))
for i in range(6):
    for j in range(6):
        for k in range(4):
            body = O.bodies[O.bodies.append(sphere((-0.01 + 0.004 * i, -0.01 + 0.004 * j, 0.002 + 0.004 * k), 0.0015,
                                                   material=material))]
            body.state.vel = (0.2, 0.1, 0.0)
thermo = series.Thermo(every=v["thermo_every"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=math.sqrt(5.0 / 6.0) * abs(beta), betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
    VTKRecorder(fileName="post/settling-", recorders=["spheres", "velocity", "mass"], iterPeriod=1000, initRun=True),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
