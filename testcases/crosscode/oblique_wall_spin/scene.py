# Cross-code scene oblique_wall_spin (YADE side; in.liggghts, in.lammps and scene.json are the same scene).
# One sphere (r = 1.5 mm, rho = 2500 kg/m^3) 1 mm above the plane z = 0 moving at (vx, 0, -0.5) m/s, no
# gravity, hits the plane z = 0 obliquely; Hertz-Mindlin with LIGGGHTS' damping
# (betan = sqrt(5/6) |beta(e)|, see ../hertz_head_on/scene.py; no tangential damping: betas = 0), e = 0.5,
# mu = 0.3, dt = 1e-5 s.
# The plane is the top of a fixed sphere of radius 1 km (of the same material): YADE's Hertz-Mindlin takes
# R* = r_a r_b / (r_a + r_b) with r_a = r_b = r for a Wall (Ip2_FrictMat_FrictMat_MindlinPhys: a Wall has no
# radius of its own, refR1 <= 0, so Da = refR2), i.e. R* = r/2, where LIGGGHTS and LAMMPS take R* = r for a
# plane. A sphere of 1 km gives R* = r (1 - 1.5e-6); its surface lies 1.3e-8 m below z = 0 at x = 5 mm, 0.02 %
# of the largest overlap.
import math
import yade_series as series

v = series.variables(vx=1.0, e=0.5, steps=500, thermo_every=2)
e = v["e"]
beta = 0.0 if e >= 1 else math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi ** 2)
material = O.materials.append(FrictMat(young=5e6, poisson=0.45, density=2500, frictionAngle=math.atan(0.3)))
O.bodies.append(sphere((0, 0, -1000.0), 1000.0, material=material, fixed=True))
ball = O.bodies.append(sphere((-0.005, 0, 0.0025), 0.0015, material=material))
O.bodies[ball].state.vel = (v["vx"], 0, -0.5)
thermo = series.Thermo(every=v["thermo_every"])
damping = math.sqrt(5.0 / 6.0) * abs(beta)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                    [Ip2_FrictMat_FrictMat_MindlinPhys(betan=damping, betas=0.0)],
                    [Law2_ScGeom_MindlinPhys_Mindlin()]),
    thermo.engine(),
    NewtonIntegrator(damping=0.0, gravity=(0, 0, 0)),
]
O.dt = 1e-5
series.start_at_full_step()
series.run(v["steps"], thermo)
