# Free fall of a 4 x 4 x 2 lattice of spheres (r = 1.5 mm, 4 mm apart: no contacts) for 0.02 s in YADE.
# Velocity Verlet (and YADE's leap-frog started at the half step, yade_series.start_at_full_step) is exact for
# a constant acceleration: ke(t) = 1/2 M |v0 + g t|^2 with M = 32 x 3.5343e-5 kg, v0 = (0.3, 0.1, 0) m/s:

import math
import yade_series as series

v = series.variables(steps=2000, thermo_every=100)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
for x in (-0.006, -0.002, 0.002, 0.006):
    for y in (-0.006, -0.002, 0.002, 0.006):
        for z in (0.04, 0.044):
            body = O.bodies[O.bodies.append(sphere((x, y, z), 0.0015, material=material))]
            body.state.vel = (0.3, 0.1, 0.0)
thermo = series.Thermo(every=v["thermo_every"])
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_MindlinPhys()],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, -9.81)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
