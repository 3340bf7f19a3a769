"""Multisphere clumps (engine/clumps.py): mass properties, rigid-body motion, contacts, insertion, output."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipj

# at module level: inside a test, "conftest" is whichever folder's conftest the session imported last
from conftest import (domain, engine_program, gravity, interaction, material, model, plane, printer, read_csv, run,
                      timestep)
from engine import clumps
from engine.kernels import Combination, generate_source

RHO = 2500.0


def template(name, spheres, t=1, **extra):
    return {"command": "create", "object": "clump_template", "name": name, "type": t, "spheres": spheres, **extra}


def clump(name, position, velocity=(0, 0, 0), omega=(0, 0, 0), orientation=None):
    cmd = {"command": "create", "object": "clump", "template": name, "position": list(position),
           "velocity": list(velocity), "omega": list(omega)}
    if orientation is not None:
        cmd["orientation"] = orientation
    return cmd


# ---------------------------------------------------------------- mass properties

def test_separate_spheres_are_exact():
    props = clumps.mass_properties([[0, 0, 0], [0.03, 0, 0]], [0.01, 0.005], RHO)
    m1, m2 = RHO * 4 / 3 * math.pi * 0.01 ** 3, RHO * 4 / 3 * math.pi * 0.005 ** 3
    com = m2 * 0.03 / (m1 + m2)
    assert props["exact"] and props["error"] == 0.0
    assert props["mass"] == pytest.approx(m1 + m2, rel=1e-14)
    assert props["com"][0] == pytest.approx(com, rel=1e-14)
    ixx = 0.4 * (m1 * 0.01 ** 2 + m2 * 0.005 ** 2)
    iyy = ixx + m1 * com ** 2 + m2 * (0.03 - com) ** 2
    assert np.allclose(np.diag(props["inertia"]), [ixx, iyy, iyy], rtol=1e-13)


def _union_of_two(r, d):
    """Volume, axial and transverse moments (about the centre, per density) of two spheres of radius r whose
    centres are d apart on z: integrals over the slices of the solid of revolution (scipy.integrate.quad)."""
    def rho2(z):  # squared slice radius at height z, centres at -d/2 and +d/2
        return max(r * r - (abs(z) - d / 2) ** 2, 0.0)
    top = d / 2 + r
    points = [0.0]
    vol = 2 * quad(lambda z: math.pi * rho2(z), 0, top, points=points)[0]
    axial = 2 * quad(lambda z: 0.5 * math.pi * rho2(z) ** 2, 0, top, points=points)[0]
    trans = 2 * quad(lambda z: math.pi * (rho2(z) ** 2 / 4 + rho2(z) * z * z), 0, top, points=points)[0]
    return vol, axial, trans


def test_overlapping_spheres_count_the_overlap_once():
    r, d = 0.01, 0.012
    props = clumps.mass_properties([[0, 0, -d / 2], [0, 0, d / 2]], [r, r], RHO, samples=2 ** 18, seed=3)
    vol, axial, trans = _union_of_two(r, d)
    lens = math.pi * (4 * r + d) * (2 * r - d) ** 2 / 12  # the overlap, counted once
    assert vol == pytest.approx(2 * 4 / 3 * math.pi * r ** 3 - lens, rel=1e-9)
    assert not props["exact"] and 0 < props["error"] < 0.01
    # the stated error bounds the real one (scrambled Sobol points do better than plain Monte Carlo)
    assert props["volume"] == pytest.approx(vol, rel=props["error"])
    assert np.allclose(props["com"], 0.0, atol=props["error"] * r)
    moments = np.sort(np.linalg.eigvalsh(props["inertia"]))
    assert moments[0] == pytest.approx(RHO * axial, rel=3 * props["error"])
    assert moments[1] == pytest.approx(RHO * trans, rel=3 * props["error"])
    assert moments[2] == pytest.approx(RHO * trans, rel=3 * props["error"])


# ---------------------------------------------------------------- compiled only where named

def test_sphere_kernels_hold_no_clump_code():
    for parallel in (False, True):
        source = generate_source(Combination(parallel=parallel, planes=True, gravity=True))
        assert "member_body" not in source and "body_pass" not in source and "bodies" not in source
        clump_source = generate_source(Combination(parallel=parallel, planes=True, gravity=True, clumps=True))
        assert "body_pass(" in clump_source and "member_body[pid[j]] == body_i" in clump_source


# ---------------------------------------------------------------- rigid-body motion

def euler_top(t, inertia, w10, w30):
    """Exact body-frame angular velocity of a free asymmetric top (I1 < I2 < I3) started at (w10, 0, w30),
    w10, w30 > 0, L^2 > 2 E I2 (rotation about the axis of the largest moment): Jacobi elliptic functions
    (Landau & Lifshitz, Mechanics, section 37)."""
    i1, i2, i3 = inertia
    l2 = (i1 * w10) ** 2 + (i3 * w30) ** 2
    e2 = i1 * w10 ** 2 + i3 * w30 ** 2
    assert l2 > e2 * i2
    a1 = math.sqrt((e2 * i3 - l2) / (i1 * (i3 - i1)))
    a2 = math.sqrt((e2 * i3 - l2) / (i2 * (i3 - i2)))
    a3 = math.sqrt((l2 - e2 * i1) / (i3 * (i3 - i1)))
    rate = math.sqrt((i3 - i2) * (l2 - e2 * i1) / (i1 * i2 * i3))
    m = (i2 - i1) * (e2 * i3 - l2) / ((i3 - i2) * (l2 - e2 * i1))
    sn, cn, dn, _ = ellipj(rate * t, m)
    return np.stack([a1 * cn, a2 * sn, a3 * dn], axis=1)


TOP = [[0.0, 0.0, 0.0, 0.01], [0.03, 0.0, 0.0, 0.008], [0.0, 0.045, 0.0, 0.006]]


def _advance_one(x, v, angmom, q, inertia, force, torque, mass, dt, kick, drift):
    """One body's step, body by body in plain Python floats (the compiled functions' own Python source, run by
    the interpreter): what advance_bodies must give to the byte."""
    half_dt = 0.5 * dt
    inv_m = 1.0 / mass
    for _ in range(int(kick) + int(drift)):
        for a in range(3):
            v[a] += half_dt * force[a] * inv_m
            angmom[a] += half_dt * torque[a]
    if drift:
        for a in range(3):
            x[a] += dt * v[a]
        q[:] = clumps.rotate.py_func(*q, *angmom, *inertia, dt)
    return clumps._omega.py_func(*q, *angmom, *inertia)


@pytest.mark.parametrize("kick, drift", [(True, True), (True, False), (False, True)])
def test_bodies_advance_in_sweeps_as_body_by_body(kick, drift):
    """advance_bodies takes the bodies BODY_CHUNK at a time (a full and a partial sweep here) and leaves the
    absent ones (present 0) as they are; each present body gets the bytes of its own step computed alone."""
    rng = np.random.default_rng(5)
    nb = clumps.BODY_CHUNK + 37
    arrays = dict(x=rng.normal(size=(nb, 3)), v=rng.normal(size=(nb, 3)), angmom=rng.normal(size=(nb, 3)) * 1e-6,
                  q=clumps.random_quaternions(rng, nb), inertia=rng.uniform(1e-9, 4e-9, (nb, 3)),
                  omega=np.zeros((nb, 3)), force=rng.normal(size=(nb, 3)), torque=rng.normal(size=(nb, 3)) * 1e-6,
                  mass=rng.uniform(1e-4, 2e-4, nb))
    present = (rng.random(nb) < 0.8).astype(np.int64)
    before = {k: a.copy() for k, a in arrays.items()}
    dt = 2e-5
    clumps.advance_bodies(**arrays, present=present, dt=dt, kick=np.bool_(kick), drift=np.bool_(drift))
    for k in range(nb):
        if not present[k]:
            assert all(np.array_equal(arrays[name][k], before[name][k]) for name in arrays), k
            continue
        x, v, angmom, q = (before[name][k].tolist() for name in ("x", "v", "angmom", "q"))
        w = _advance_one(x, v, angmom, q, before["inertia"][k].tolist(), before["force"][k].tolist(),
                         before["torque"][k].tolist(), float(before["mass"][k]), dt, kick, drift)
        for name, value in (("x", x), ("v", v), ("angmom", angmom), ("q", q), ("omega", w)):
            assert arrays[name][k].tobytes() == np.array(value, dtype=np.float64).tobytes(), (k, name)
    assert not np.array_equal(arrays["q"], before["q"]) or not drift


def test_free_asymmetric_top_follows_euler(engine_run):
    """Torque-free precession: the body-frame angular velocity against the exact solution, and the angular
    momentum conserved (to round-off: without torque the integrator never changes it)."""
    top = clumps.Template("top", 1, np.array(TOP)[:, :3], np.array(TOP)[:, 3], RHO, 1024, 0)
    i1, i2, i3 = top.moments
    assert i1 < i2 < i3 and (i2 - i1) > 0.05 * i3 and (i3 - i2) > 0.05 * i3
    w10, w30 = 3.0, 10.0
    # the orientation that turns the principal axes onto x, y, z: body frame = space frame at t = 0
    q_inv = top.q_axes * np.array([1, -1, -1, -1])
    dt, steps, every = 2e-5, 50000, 500
    code, folder = engine_run([domain(), material(rho=RHO), interaction(), model(), template("top", TOP),
                               clump("top", [0, 0, 0], omega=[w10, 0, w30],
                                     orientation={"quaternion": q_inv.tolist()}), timestep(dt)]
                              + printer(every, ["body_w1[1]", "body_w2[1]", "body_w3[1]", "body_lx[1]",
                                                "body_ly[1]", "body_lz[1]", "rke"]) + [run(steps)])
    assert code == 0
    s = read_csv(folder / "series.csv")
    t = s["step"] * dt
    w = np.stack([s["body_w1[1]"], s["body_w2[1]"], s["body_w3[1]"]], axis=1)
    assert w[0] == pytest.approx([w10, 0.0, w30], abs=1e-9)
    exact = euler_top(t, (i1, i2, i3), w10, w30)
    assert np.ptp(exact[:, 0]) > 4.0  # the body axis wobbles: a real test of the rotation
    assert np.max(np.abs(w - exact)) < 1e-4 * w30
    angmom = np.stack([s["body_lx[1]"], s["body_ly[1]"], s["body_lz[1]"]], axis=1)
    assert np.max(np.abs(angmom - angmom[0])) <= 1e-14 * np.linalg.norm(angmom[0])
    energy = 0.5 * (i1 * w10 ** 2 + i3 * w30 ** 2)
    assert s["rke"] == pytest.approx(np.full(len(t), energy), rel=1e-6)


def test_members_of_one_clump_do_not_touch(engine_run):
    """Overlapping members at rest, no gravity: no contact, no force, no motion."""
    spheres = [[-0.004, 0, 0, 0.005], [0.004, 0, 0, 0.005], [0, 0.004, 0.002, 0.004]]
    code, folder = engine_run([domain(), material(), interaction(), model(), template("blob", spheres),
                               clump("blob", [0.1, 0.2, 0.3]), timestep(1e-5)]
                              + printer(100, ["contacts", "max_overlap", "body_x[1]", "ke", "fx[1]", "fy[2]"])
                              + [run(1000)])
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert np.all(s["contacts"] == 0) and np.all(s["max_overlap"] == 0) and np.all(s["ke"] == 0)
    assert np.all(s["body_x[1]"] == 0.1)


def _bounce(engine_run, e, sub, spheres=None, radius=0.005, sphere_density=None):
    """A dumbbell (or one sphere) dropped flat on a plane at 1 m/s, no gravity: velocity before / after."""
    rho = sphere_density or RHO
    body = ([template("db", spheres), clump("db", [0, 0, radius + 0.001], velocity=[0, 0, -1.0])] if spheres else
            [{"command": "create", "object": "particle", "type": 1, "radius": radius,
              "position": [0, 0, radius + 0.001], "velocity": [0, 0, -1.0]}])
    quantity = "body_vz[1]" if spheres else "vz[1]"
    code, folder = engine_run([domain(), material(rho=rho), interaction(e=e, mu=0.0), model("hertz", "none"),
                               plane("floor", "z", 0.0), *body, timestep(2e-7)]
                              + printer(200, [quantity, "rke"]) + [run(20000)], sub=sub)
    assert code == 0
    s = read_csv(folder / "series.csv")
    return s[quantity][-1], s["rke"]


def test_dumbbell_dropped_flat_bounces_like_a_sphere(engine_run):
    """Two touching spheres dropped flat: elastic (e = 1), the clump leaves at the speed it came (a sphere of
    its mass would); with damping each member contact is damped with the clump's mass (as LIGGGHTS' multisphere
    model does) while it carries half of it, so the damping ratio is sqrt(2) that of a sphere of the clump's
    mass: the restitution follows from the linear-spring estimate e' = exp(-pi z' / sqrt(1 - z'^2))."""
    r = 0.005
    spheres = [[-r, 0, 0, r], [r, 0, 0, r]]
    v_after, rke = _bounce(engine_run, 1.0, "elastic", spheres)
    assert v_after == pytest.approx(1.0, rel=1e-3)
    assert np.all(rke < 1e-12)  # dropped flat: it does not start to turn
    v_sphere, _ = _bounce(engine_run, 0.5, "sphere", radius=r, sphere_density=2 * RHO)  # a sphere of its mass
    v_clump, _ = _bounce(engine_run, 0.5, "damped", spheres)
    zeta = -math.log(0.5) / math.sqrt(math.log(0.5) ** 2 + math.pi ** 2)
    zeta2 = math.sqrt(2) * zeta
    predicted = math.exp(-math.pi * zeta2 / math.sqrt(1 - zeta2 ** 2))
    assert v_sphere == pytest.approx(0.5, abs=0.05)
    assert v_clump == pytest.approx(predicted, abs=0.03)
    assert v_clump < v_sphere


def test_standing_dumbbell_falls_to_its_stable_orientation(engine_run):
    """A dumbbell standing on one end, tilted by 5 degrees, with friction and gravity, comes to rest lying
    flat: its centre of mass drops from r + r to r (the lowest it can be)."""
    r = 0.005
    spheres = [[-r, 0, 0, r], [r, 0, 0, r]]
    tilt = {"axis": [0, 1, 0], "angle": -85.0}  # the axis x almost vertical
    code, folder = engine_run([domain(), material(), interaction(e=0.3, mu=0.5), model(), plane("floor", "z", 0.0)]
                              + gravity() + [template("db", spheres),
                                             clump("db", [0, 0, 2 * r + 0.0001], orientation=tilt), timestep(1e-5)]
                              + printer(1000, ["body_z[1]", "ke", "rke", "z[1]", "z[2]"]) + [run(60000)])
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["body_z[1]"][0] > 1.9 * r
    assert s["body_z[1]"][-1] == pytest.approx(r, rel=0.02)
    assert abs(s["z[1]"][-1] - s["z[2]"][-1]) < 0.02 * r  # both members on the floor
    assert s["ke"][-1] + s["rke"][-1] < 1e-9


# ---------------------------------------------------------------- insertion, output, restart, time step

def _pile(count=40, steps=4000, restart=None, dump=False):
    box = {"shape": "box", "lo": [-0.015, -0.015, 0.0], "hi": [0.015, 0.015, 0.05]}
    commands = [domain((-0.02, -0.02, -0.001), (0.02, 0.02, 0.06)), material(), interaction(mu=0.4), model(),
                plane("floor", "z", 0.0),
                {"command": "create", "object": "wall", "name": "drum", "shape": "cylinder", "center": [0, 0],
                 "radius": 0.019, "side": "inside", "type": 1}]
    commands += gravity() + [template("rod", [[-0.0015, 0, 0, 0.0015], [0, 0, 0, 0.0015], [0.0015, 0, 0, 0.0015]],
                                      samples=8192),
                             {"command": "create", "object": "modifier", "name": "feed", "kind": "insert",
                              "template": "rod", "every": 500, "rate": 20000, "total": count, "seed": 2,
                              "region": {"shape": "cylinder", "center": [0, 0], "radius": 0.015, "z": [0.003, 0.03]}},
                             {"command": "fix", "name": "feed"}, timestep(1e-5)]
    commands += printer(500, ["ke", "rke", "com_z", "body_z[3]", "inserted_count[feed]", "mass[type=1]",
                              "atoms", "contacts"])
    if dump:
        commands += [{"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": steps},
                     {"command": "fix", "name": "dump"}]
    if restart:
        commands += [run(steps // 2), {"command": "create", "object": "restart", "file": restart}, run(steps // 2)]
    else:
        commands.append(run(steps))
    return commands


def test_insert_modifier_inserts_clumps_and_vtk_names_their_bodies(engine_run):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    code, folder = engine_run(_pile(steps=8000, dump=True))
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["inserted_count[feed]"][-1] == 40 and s["atoms"][-1] == 120
    mass = clumps.mass_properties([[-0.0015, 0, 0], [0, 0, 0], [0.0015, 0, 0]], [0.0015] * 3, RHO, 8192)["mass"]
    assert s["mass[type=1]"][-1] == pytest.approx(40 * mass, rel=1e-12)
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(folder / "post" / "particles_8000.vtp"))
    reader.Update()
    data = reader.GetOutput().GetPointData()
    ids = vtk_to_numpy(data.GetArray("id"))
    body = vtk_to_numpy(data.GetArray("body"))
    assert np.array_equal(body, (ids - 1) // 3 + 1)  # inserted three members at a time, ids in order
    # contacts: overlapping members of different bodies only (brute force over the dumped spheres)
    x = vtk_to_numpy(reader.GetOutput().GetPoints().GetData())
    radius = vtk_to_numpy(data.GetArray("radius"))
    gap = np.linalg.norm(x[:, None] - x[None, :], axis=2) - (radius[:, None] + radius[None, :])
    other = body[:, None] != body[None, :]
    assert s["contacts"][-1] == np.count_nonzero(np.triu((gap < 0) & other, 1)) > 0
    assert np.count_nonzero(np.triu((gap < -1e-9) & ~other, 1)) == 40 * 2  # neighbouring members overlap


def test_restart_continues_a_clump_pile_bitwise(engine_run):
    code, folder = engine_run(_pile(restart="half.restart"), sub="long")
    assert code == 0
    long = (folder / "series.csv").read_text().splitlines()
    cont = [c for c in _pile() if c.get("object") not in ("domain", "wall") and c["command"] != "run"]
    cont = [c for c in cont if not (c["command"] == "fix" and c["name"] == "feed")]  # its counters: the file's
    cont = cont[:4] + [{"command": "set", "property": "restart", "file": str(folder / "half.restart")}] + cont[4:]
    code, folder2 = engine_run(cont + [{"command": "fix", "name": "feed"}, run(2000)], sub="cont")
    assert code == 0
    rows = (folder2 / "series.csv").read_text().splitlines()
    assert rows[-1] == long[-1] and len(rows) > 3


def test_critical_timestep_takes_the_smallest_member(engine_run):
    spheres = [[0, 0, 0, 0.01], [0.012, 0, 0, 0.002]]
    code, folder = engine_run([domain(), material(), interaction(), model(), template("pear", spheres),
                               clump("pear", [0, 0, 0]), {"command": "get", "property": "critical_timestep"}])
    assert code == 0
    line = [ln for ln in (folder / "log.dem").read_text().splitlines() if "rayleigh_time =" in ln][0]
    t_r = float(line.split("rayleigh_time = ")[1].split(" s")[0])
    shear = 1e7 / (2 * 1.3)
    assert t_r == pytest.approx(math.pi * 0.002 * math.sqrt(RHO / shear) / (0.1631 * 0.3 + 0.8766), rel=1e-12)


@pytest.mark.parametrize("bad, message", [
    ({"spheres": []}, "field 'spheres' must be a non-empty list"),
    ({"spheres": [[0, 0, 0, -1]]}, "every radius must be > 0"),
])
def test_bad_templates_are_bad_input(engine_run, bad, message):
    cmd = template("t", [[0, 0, 0, 0.01]])
    cmd.update(bad)
    code, folder = engine_run([domain(), material(), cmd])
    assert code == 2
    assert message in (folder / "log.dem").read_text()


def test_clump_of_an_unknown_template_is_bad_input(engine_run):
    code, folder = engine_run([domain(), material(), clump("none", [0, 0, 0])])
    assert code == 2
    assert "field 'template' names no clump template 'none'" in (folder / "log.dem").read_text()


@pytest.mark.slow
def test_clump_pile_is_bitwise_the_same_on_one_and_two_threads(tmp_path):
    """The body pass is serial and the pair loop's skip writes the pair's row: thermo bytes equal."""
    scene = _pile(count=40, steps=3000)
    rows = []
    for threads in ("1", "2"):
        done = engine_program(tmp_path / threads, scene, "-threads", threads)
        assert done.returncode == 0, done.stdout[-2000:]
        rows.append((tmp_path / threads / "series.csv").read_bytes())
    assert rows[0] == rows[1]


def test_outlet_removes_whole_clumps_and_mass_rate_inserts_clumps(engine_run):
    """An outlet takes a clump as soon as one member's centre is in its region; an insert modifier in mass
    mode counts clump masses."""
    rod = [[-0.0015, 0, 0, 0.0015], [0, 0, 0, 0.0015], [0.0015, 0, 0, 0.0015]]
    mass = clumps.mass_properties(np.array(rod)[:, :3], np.array(rod)[:, 3], RHO, 8192)["mass"]
    commands = [domain((-0.02, -0.02, -0.05), (0.02, 0.02, 0.06)), material(), interaction(), model()]
    commands += gravity() + [
        template("rod", rod, samples=8192),
        {"command": "create", "object": "modifier", "name": "feed", "kind": "insert", "template": "rod",
         "every": 1000, "mass_rate": 2.5 * mass / (1000 * 1e-5), "total_mass": 10.5 * mass, "seed": 4,
         "region": {"shape": "box", "lo": [-0.015, -0.015, 0.02], "hi": [0.015, 0.015, 0.05]}},
        {"command": "fix", "name": "feed"},
        {"command": "create", "object": "modifier", "name": "drain", "kind": "outlet", "every": 100,
         "region": {"shape": "box", "lo": [-0.02, -0.02, -0.05], "hi": [0.02, 0.02, 0.0]}},
        {"command": "fix", "name": "drain"}, timestep(1e-5)]
    commands += printer(100, ["atoms", "inserted_count[feed]", "inserted_mass[feed]", "removed_count[drain]",
                              "removed_mass[drain]", "mass[type=1]"]) + [run(12000)]
    code, folder = engine_run(commands)
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["inserted_count[feed]"][-1] == 10  # 10 clumps fit under 10.5 clump masses
    assert s["inserted_mass[feed]"][-1] == pytest.approx(10 * mass, rel=1e-12)
    assert s["removed_count[drain]"][-1] > 0
    assert np.all(s["atoms"] % 3 == 0) and np.all(s["removed_count[drain]"] % 3 == 0)
    removed = s["removed_count[drain]"] / 3
    assert s["removed_mass[drain]"] == pytest.approx(removed * mass, rel=1e-12)
    assert s["mass[type=1]"] == pytest.approx(s["atoms"] / 3 * mass, rel=1e-12)


# ---------------------------------------------------------------- periodic axes

def _collision(engine_run, shift, sub):
    """Two tilted, spinning dumbbells meet obliquely (friction 0.5, no gravity) in a box periodic along x
    (40 mm), their configuration moved by ``shift`` (m) along x: 0 meets in the middle, 0.02 across the
    boundary. Per row: both bodies' x, velocity, angular velocity, and the pair statistics."""
    r = 0.002
    spheres = [[-r, 0, 0, r], [r, 0, 0, r]]
    tilt_a = {"axis": [0, 0, 1], "angle": 30.0}
    tilt_b = {"axis": [1, 1, 0], "angle": -50.0}
    half = 0.02
    columns = ["body_x[1]", "body_x[2]", "contacts", "max_overlap", "ke", "rke"] + [
        f"body_{q}[{b}]" for b in (1, 2) for q in ("vx", "vy", "vz", "omegax", "omegay", "omegaz")]
    code, folder = engine_run([domain(lo=(-half, -0.05, -0.05), hi=(half, 0.05, 0.05), periodic=(True, False, False)),
                               material(), interaction(e=0.5, mu=0.5), model(), template("db", spheres),
                               clump("db", [-0.006 + shift, 0.0015, 0.0], velocity=[0.5, 0, 0], omega=[0, 0, 20.0],
                                     orientation=tilt_a),
                               clump("db", [0.006 + shift, -0.0015, 0.0005], velocity=[-0.5, 0, 0],
                                     omega=[10.0, 0, 0], orientation=tilt_b),
                               timestep(1e-5)] + printer(20, columns) + [run(1500)], sub=sub)
    assert code == 0, (folder / "log.dem").read_text()[-2000:]
    return read_csv(folder / "series.csv")


def test_clumps_collide_across_a_periodic_boundary_as_inside_the_box(engine_run):
    """The same collision in the middle of the box and across its periodic boundary: the same motion (to
    round-off of the wrapped coordinates), the same contacts and overlaps, the centres of mass a half period
    apart and inside the box."""
    inside = _collision(engine_run, 0.0, "inside")
    across = _collision(engine_run, 0.02, "across")
    assert inside["contacts"].max() >= 1 and inside["max_overlap"].max() > 0
    # a real collision: the bodies turned each other
    assert abs(inside["body_vx[1]"][-1] - 0.5) > 0.1 and abs(inside["body_omegay[1]"][-1]) > 1.0
    np.testing.assert_array_equal(across["contacts"], inside["contacts"])
    np.testing.assert_allclose(across["max_overlap"], inside["max_overlap"], rtol=1e-6, atol=1e-9)
    for name in inside:
        if name.startswith(("body_v", "body_omega")) or name in ("ke", "rke"):
            np.testing.assert_allclose(across[name], inside[name], rtol=1e-7, atol=1e-9, err_msg=name)
    for b in (1, 2):
        x = across[f"body_x[{b}]"]
        assert np.all((x >= -0.02) & (x < 0.02))
        shifted = (inside[f"body_x[{b}]"] + 0.02 + 0.02) % 0.04 - 0.02
        np.testing.assert_allclose(x, shifted, atol=1e-9)


def test_a_clump_longer_than_half_a_period_is_bad_input(engine_run):
    """The lever arms are nearest images: a period must be more than the clump's bounding diameter."""
    long_rod = [[-0.006, 0, 0, 0.002], [0.006, 0, 0, 0.002]]          # bounding radius 8 mm
    code, folder = engine_run([domain(lo=(-0.0075, -0.05, -0.05), hi=(0.0075, 0.05, 0.05),
                                      periodic=(True, False, False)),
                               material(), interaction(), model(), template("rod", long_rod),
                               clump("rod", [0, 0, 0]), timestep(1e-5), run(10)])
    assert code != 0
    assert "periodic length along x must be more than twice the largest clump template's bounding radius " \
           "(0.016 m)" in (folder / "log.dem").read_text()
