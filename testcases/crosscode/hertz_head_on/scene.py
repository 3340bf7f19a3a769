# Cross-code scene hertz_head_on (YADE side; in.liggghts, in.lammps and scene.json are the same scene).
# Two spheres (r = 1.5 mm, rho = 2500 kg/m^3) 4 mm apart approach head-on at 0.5 m/s each, no gravity.
# LIGGGHTS' Hertz model in YADE's Hertz-Mindlin law (Ip2_FrictMat_FrictMat_MindlinPhys, Law2..._Mindlin):
#   k_n = 4/3 E* sqrt(R*) (E* as LIGGGHTS), viscous c_n = 2 betan sqrt(m* 2 E* a): with
#   betan = sqrt(5/6) |beta(e)| it is LIGGGHTS' 2 sqrt(5/6) |beta| sqrt(Sn m*), Sn = 2 E* a; betas likewise.
#   Newton's numerical damping is off (YADE's default is 0.2).
import math
import yade_series as series

v = series.variables(e=0.5, steps=150, thermo_every=1)
beta = 0.0 if v["e"] >= 1 else math.log(v["e"]) / math.sqrt(math.log(v["e"]) ** 2 + math.pi ** 2)
O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
O.bodies.append([sphere((-0.002, 0, 0), 0.0015), sphere((0.002, 0, 0), 0.0015)])
O.bodies[0].state.vel = (0.5, 0, 0)
O.bodies[1].state.vel = (-0.5, 0, 0)
thermo = series.Thermo(every=v["thermo_every"])
damping = math.sqrt(5.0 / 6.0) * abs(beta)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=damping, betas=damping)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, 0)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
