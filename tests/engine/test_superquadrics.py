"""Superquadric particles (engine/superquadrics.py): shape, contact detection, motion, output."""
import json
import math

import numpy as np
import pytest

# at module level: inside a test, "conftest" is whichever folder's conftest the session imported last
from conftest import domain, gravity, interaction, material, model, plane, read_csv, run, timestep
from engine import clumps, superquadrics
from engine.kernels import Combination, generate_source

RHO = 2500.0


def sq(position, half_axes, blockiness=2, velocity=(0, 0, 0), omega=(0, 0, 0), orientation=None, t=1):
    cmd = {"command": "create", "object": "superquadric", "type": t, "half_axes": list(half_axes),
           "blockiness": blockiness, "position": list(position), "velocity": list(velocity), "omega": list(omega)}
    if orientation is not None:
        cmd["orientation"] = orientation
    return cmd


def thermo(every, columns):
    return {"command": "set", "property": "thermo", "every": every, "columns": columns}


def grid_integrals(a, b, c, n1, n2, cells=160):
    """Volume and the moments Ixx, Izz (per unit density) by counting the centres of a cells^3 grid over the
    bounding box that lie inside: an independent check of the closed forms."""
    s = (np.arange(cells) + 0.5) / cells * 2 - 1
    x, y, z = np.meshgrid(s * a, s * b, s * c, indexing="ij")
    inside = (np.abs(x / a) ** n2 + np.abs(y / b) ** n2) ** (n1 / n2) + np.abs(z / c) ** n1 <= 1
    dv = 8 * a * b * c / cells ** 3
    return (inside.sum() * dv, ((y * y + z * z) * inside).sum() * dv, ((x * x + y * y) * inside).sum() * dv)


# ---------------------------------------------------------------- shape


def test_sphere_mass_properties_are_exact():
    p = superquadrics.mass_properties(0.01, 0.01, 0.01, 2, 2, RHO)
    m = RHO * 4 / 3 * math.pi * 1e-6
    assert p["mass"] == pytest.approx(m, rel=1e-13)
    assert np.allclose(p["moments"], 0.4 * m * 1e-4, rtol=1e-13)


@pytest.mark.parametrize("shape", [(2.0, 1.0, 0.5, 2, 2), (1.0, 0.8, 0.6, 8, 8), (1.0, 0.7, 0.5, 4, 10),
                                   (0.6, 0.9, 1.2, 10, 3)])
def test_mass_properties_match_grid_integration(shape):
    p = superquadrics.mass_properties(*shape, 1.0)
    volume, ixx, izz = grid_integrals(*shape)
    # the grid's error is of order 1/cells of the volume (about 0.6 % at 160 cells; measured below 0.2 %)
    assert p["volume"] == pytest.approx(volume, rel=4e-3)
    assert p["moments"][0] == pytest.approx(ixx, rel=4e-3)
    assert p["moments"][2] == pytest.approx(izz, rel=4e-3)


def test_support_point_is_on_the_surface_with_the_normal_along_the_direction():
    a, b, c, n1, n2 = 1.0, 0.7, 0.5, 4.0, 10.0
    for u in np.random.default_rng(1).normal(size=(20, 3)):
        p = np.array(superquadrics.support_point(a, b, c, n1, n2, *u))
        f = (abs(p[0] / a) ** n2 + abs(p[1] / b) ** n2) ** (n1 / n2) + abs(p[2] / c) ** n1
        assert f == pytest.approx(1.0, abs=1e-12)
        # the farthest point along u: no point of a fine sample of the surface lies farther
        others = np.array([superquadrics.support_point(a, b, c, n1, n2, *v)
                           for v in np.random.default_rng(2).normal(size=(300, 3))])
        assert np.all(others @ u <= p @ u + 1e-12)


def test_ellipsoid_curvature_radius_at_its_tips():
    """At (a, 0, 0) the principal curvatures of an ellipsoid are a/b^2 and a/c^2."""
    a, b, c = 0.01, 0.006, 0.004
    expected = 2.0 / (a / b ** 2 + a / c ** 2)
    assert superquadrics.curvature_radius(a, b, c, 2, 2, a, 0, 0, 1.0) == pytest.approx(expected, rel=1e-12)
    assert superquadrics.curvature_radius(0.01, 0.01, 0.01, 2, 2, 0.006, 0, 0.008, 1.0) == pytest.approx(0.01)
    # the smallest over the surface is at the tip of the longest axis
    assert superquadrics.smallest_curvature_radius(a, b, c, 2, 2) == pytest.approx(expected, rel=1e-9)
    # a face of a blocky body is flat at its centre: the cap
    assert superquadrics.curvature_radius(a, a, a, 8, 8, 0, 0, a, 0.02) == 0.02


def _bodies(shapes, centres, quaternions):
    q = np.array(quaternions, float)
    q /= np.linalg.norm(q, axis=1)[:, None]
    return np.array(centres, float), clumps.rotation_matrices(q), np.array(shapes, float)


@pytest.mark.parametrize("shapes, centres", [
    ([[1, 0.5, 0.3, 2, 2], [0.8, 0.6, 0.4, 2, 2]], [[0.9, 0.7, 0.3], [0, 0, 0]]),
    ([[1, 0.5, 0.3, 8, 8], [0.8, 0.6, 0.4, 6, 3]], [[1.2, 0.5, 0.3], [0, 0, 0]]),
])
def test_penetration_depth_is_the_smallest_overlap_over_all_directions(shapes, centres):
    """The Newton search against the overlap along 200,000 random directions (its minimum is the depth)."""
    x, rot, shape = _bodies(shapes, centres, [[1, 0.2, 0.1, 0], [0.9, 0.1, 0.3, 0.2]])
    d, nx, ny, nz, _ = superquadrics.pair_contact(x, rot, shape, 0, 1, *(x[0] - x[1]), 3.0, True)
    directions = np.random.default_rng(0).normal(size=(200_000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    brute = min(superquadrics._along(x, rot, shape, 0, 1, *u)[0] for u in directions)
    assert 0 < d <= brute + 1e-12
    assert d == pytest.approx(brute, rel=5e-3)  # the sampling's own error
    # at the minimum the two support points are joined along the normal (to 1e-6 of the bodies' size: near a
    # blocky body's edge d(n) is nearly a kink, and the search stops on the depth's decrease)
    _, wx, wy, wz = superquadrics._along(x, rot, shape, 0, 1, nx, ny, nz)
    w = np.array([wx, wy, wz])
    assert np.linalg.norm(w - (w @ [nx, ny, nz]) * np.array([nx, ny, nz])) < 1e-6


def test_separated_bodies_have_no_contact():
    x, rot, shape = _bodies([[1, 0.5, 0.3, 2, 2], [1, 0.5, 0.3, 2, 2]], [[0, 0, 0.61], [0, 0, 0]],
                            [[1, 0, 0, 0], [1, 0, 0, 0]])
    assert superquadrics.pair_contact(x, rot, shape, 0, 1, 0.3, 0.2, 1.0, 2.0, False)[0] < 0
    x[0, 2] = 0.59
    d, nx, ny, nz, _ = superquadrics.pair_contact(x, rot, shape, 0, 1, 0.3, 0.2, 1.0, 2.0, False)
    assert d == pytest.approx(0.01, rel=1e-9) and nz == pytest.approx(1.0)


# ---------------------------------------------------------------- motion


def _scene(bodies, walls=(), mu=0.3, e=0.5, g=True, dt=2e-6, steps=20000, every=1000, columns=(), normal="hertz",
           tangential="history"):
    return [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(rho=RHO), interaction(e=e, mu=mu),
            model(normal=normal, tangential=tangential,
                  **({"characteristic_velocity": 1.0} if normal == "hooke" else {})), *walls, *(gravity() if g else []), *bodies, timestep(dt),
            thermo(every, list(columns)), run(steps)]


@pytest.mark.parametrize("normal, tangential", [("hertz", "history"), ("hooke", "no_history")])
def test_round_superquadrics_follow_the_spheres(engine_run, normal, tangential):
    """n = 2 and a = b = c: the trajectories of two spheres (one bouncing with spin and friction on the floor,
    the other landing on it) to round-off, with either normal law."""
    r = 0.005
    start = [dict(position=(0, 0, 0.006), velocity=(0.3, 0, -1.0), omega=(0, 5, 0)),
             dict(position=(0.002, 0.001, 0.02), velocity=(0, 0, -1.0), omega=(0, 0, 0))]
    names = ["x", "y", "z", "vx", "vz", "omegax", "omegay", "omegaz"]
    floor = [plane("floor", "z", 0.0)]
    spheres = [{"command": "create", "object": "particle", "type": 1, "radius": r, "position": list(b["position"]),
                "velocity": list(b["velocity"]), "omega": list(b["omega"])} for b in start]
    bodies = [sq(b["position"], (r, r, r), 2, b["velocity"], b["omega"]) for b in start]
    laws = dict(normal=normal, tangential=tangential)
    code, folder = engine_run(_scene(spheres, floor, columns=[f"{n}[{k}]" for k in (1, 2) for n in names], **laws),
                              sub="spheres")
    assert code == 0
    want = read_csv(folder / "thermo.csv")
    code, folder = engine_run(_scene(bodies, floor, columns=[f"sq_{n}[{k}]" for k in (1, 2) for n in names],
                                     **laws), sub="superquadrics")
    assert code == 0, (folder / "log.dem").read_text()
    got = read_csv(folder / "thermo.csv")
    assert abs(want["omegay[2]"]).max() > 1.0 and abs(want["x[2]"] - 0.002).max() > 1e-3  # they met and turned
    for k in (1, 2):
        for n in names:
            scale = np.abs(want[f"{n}[{k}]"]).max()
            assert np.abs(got[f"sq_{n}[{k}]"] - want[f"{n}[{k}]"]).max() <= 1e-10 * scale, (n, k)
    assert np.allclose(got["ke"], want["ke"], rtol=1e-10) and np.allclose(got["rke"], want["rke"], rtol=1e-9)


def _incline(theta_deg, mu, steps):
    """An ellipsoid (10 x 6 x 4 mm, lying flat) on a plane tilted by theta through the origin."""
    th = math.radians(theta_deg)
    normal = [-math.sin(th), 0.0, math.cos(th)]
    centre = [(0.004 + 1e-5) * v for v in normal]
    wall = {"command": "create", "object": "wall", "name": "incline", "shape": "plane", "point": [0, 0, 0],
            "normal": normal, "type": 1}
    body = sq(centre, (0.01, 0.006, 0.004), 2, orientation={"axis": [0, 1, 0], "angle": -theta_deg})
    return _scene([body], [wall], mu=mu, e=0.3, dt=1e-5, steps=steps, every=200,
                  columns=["sq_x[1]", "sq_z[1]", "sq_vx[1]", "sq_vz[1]"])


def _downhill(folder, theta_deg, mu):
    """The body's travel down the incline of the run in folder, from its thermo: time (s), distance s (m), the
    rows after t = 0.2 s (once landed), the fitted acceleration along the slope over them (m/s^2) and the
    analytic g (sin theta - mu cos theta)."""
    t_series = read_csv(folder / "thermo.csv")
    th = math.radians(theta_deg)
    down = np.array([-math.cos(th), -math.sin(th)])  # downhill along the incline, in the x-z plane
    s = t_series["sq_x[1]"] * down[0] + t_series["sq_z[1]"] * down[1]
    v = t_series["sq_vx[1]"] * down[0] + t_series["sq_vz[1]"] * down[1]
    time = t_series["time"]
    late = time >= 0.2
    acceleration = np.polyfit(time[late], v[late], 1)[0]
    return time, s, late, acceleration, 9.81 * (math.sin(th) - mu * math.cos(th))


@pytest.mark.parametrize("theta, slides", [(24.0, False), (29.0, True), (35.0, True)])
def test_ellipsoid_on_an_incline_slides_exactly_when_tan_theta_exceeds_mu(engine_run, theta, slides):
    """Lying flat, it cannot roll away (its centre would rise); it rocks on its flat side, undamped since the
    contact point does not slip, and near the threshold slips a little while it lands (about 2 mm at 24
    degrees in the first 0.15 s). After that: at rest on average below the threshold, sliding with the
    acceleration g (sin theta - mu cos theta) above it (a straight-line fit over the rocking)."""
    mu = 0.5  # tan(theta) = mu at 26.57 degrees
    code, folder = engine_run(_incline(theta, mu, 80000), sub=f"incline{theta}")
    assert code == 0, (folder / "log.dem").read_text()
    time, s, late, acceleration, analytic = _downhill(folder, theta, mu)
    if slides:
        assert acceleration == pytest.approx(analytic, rel=0.03)
        assert s[-1] - s[late][0] > 0.9 * analytic * (time[-1] ** 2 - 0.2 ** 2) / 2
    else:
        assert abs(acceleration) < 0.005 * 9.81 * math.sin(math.radians(theta))
        assert np.abs(s[late] - s[late].mean()).max() < 2e-4  # rocks in place


def _collision(bodies, dt=1e-6, steps=30000):
    cols = [f"sq_{n}[{k}]" for k in (1, 2) for n in ("x", "y", "z", "vx", "vy", "vz", "lx", "ly", "lz")]
    return _scene(bodies, (), mu=0.0, e=1.0, g=False, dt=dt, steps=steps, every=100, columns=cols)


ELLIPSOID = (0.01, 0.006, 0.004)


def test_ellipsoids_colliding_head_on_without_damping_conserve_energy(engine_run):
    """Along their long axes (the curvature radius at the contact stays that of the tips), e = 1: the energy
    after the contact is the energy before to 1e-8 (measured: -7.7e-10 at dt = 1e-6 s, -3.8e-10 at 2.5e-7 s)."""
    bodies = [sq((-0.011, 0, 0), ELLIPSOID, 2, velocity=(1.0, 0, 0), omega=(30, 0, 0)),
              sq((0.011, 0, 0), ELLIPSOID, 2, velocity=(-0.5, 0, 0))]
    code, folder = engine_run(_collision(bodies), sub="head_on")
    assert code == 0, (folder / "log.dem").read_text()
    t = read_csv(folder / "thermo.csv")
    energy = t["ke"] + t["rke"]
    assert t["sq_vx[1]"][-1] == pytest.approx(-0.5, rel=1e-4) and t["sq_vx[2]"][-1] == pytest.approx(1.0, rel=1e-4)
    assert abs(energy[-1] - energy[0]) < 1e-8 * energy[0]


def test_colliding_ellipsoids_conserve_momentum_and_angular_momentum(engine_run):
    """Two ellipsoids, turned and spinning, meet off-centre (e = 1, no friction, no gravity): momentum and
    angular momentum about the origin to round-off (equal and opposite forces at one contact point). The
    energy changes by +0.71 % whatever the time step (dt = 1e-6 s and 2.5e-7 s agree to 1e-10): the Hertz
    stiffness follows the curvature radius at the moving contact point, so the force is not the gradient of
    one potential (docs/shapes.md)."""
    bodies = [sq((-0.012, 0.003, 0.001), ELLIPSOID, 2, velocity=(1.0, 0, 0), omega=(0, 0, 20),
                 orientation={"axis": [1, 1, 0], "angle": 30}),
              sq((0.012, -0.002, 0.0), ELLIPSOID, [2, 2], velocity=(-0.5, 0.1, 0), omega=(10, 0, 0),
                 orientation={"axis": [0, 1, 1], "angle": 70})]
    code, folder = engine_run(_collision(bodies), sub="oblique")
    assert code == 0, (folder / "log.dem").read_text()
    t = read_csv(folder / "thermo.csv")
    m = superquadrics.mass_properties(*ELLIPSOID, 2, 2, RHO)["mass"]
    energy = t["ke"] + t["rke"]
    assert t["sq_vx[1]"][-1] < t["sq_vx[1]"][0] - 0.3 and np.abs(np.diff(t["sq_vx[1]"][-5:])).max() == 0.0
    assert abs(energy[-1] / energy[0] - 1.0071284) < 1e-5
    for axis in "xyz":
        p = m * (t[f"sq_v{axis}[1]"] + t[f"sq_v{axis}[2]"])
        assert np.abs(p - p[0]).max() < 1e-12 * m
    angular = np.zeros((len(t["time"]), 3))
    for k in (1, 2):
        x = np.stack([t[f"sq_{n}[{k}]"] for n in "xyz"], 1)
        v = np.stack([t[f"sq_v{n}[{k}]"] for n in "xyz"], 1)
        angular += np.stack([t[f"sq_l{n}[{k}]"] for n in "xyz"], 1) + m * np.cross(x, v)
    assert np.abs(angular - angular[0]).max() < 1e-10 * np.abs(angular[0]).max()


@pytest.mark.parametrize("axis, angle", [([1, 0.3, 0], 35.0), ([0, 1, 0], 40.0)])
def test_blocky_body_comes_to_rest_on_a_face(engine_run, axis, angle):
    """n = 8 (nearly a cube of side 10 mm) dropped tilted onto a plane with friction: it ends on a face (centre
    at the half-height c, one axis vertical), not on an edge (centre about 7 mm up, axes at 45 degrees)."""
    c = 0.005
    body = sq((0, 0, 0.009), (c, c, c), 8, orientation={"axis": axis, "angle": angle})
    code, folder = engine_run(_scene([body], [plane("floor", "z", 0.0)], mu=0.5, e=0.3, dt=5e-6, steps=100000,
                                     every=5000, columns=["sq_z[1]", "sq_qw[1]", "sq_qx[1]", "sq_qy[1]",
                                                          "sq_qz[1]"]), sub="blocky")
    assert code == 0, (folder / "log.dem").read_text()
    t = read_csv(folder / "thermo.csv")
    assert t["sq_z[1]"][-1] == pytest.approx(c, abs=0.05 * c)  # the overlap under its weight: 13 um
    q = np.array([t[f"sq_q{n}[1]"][-1] for n in "wxyz"])
    rot = clumps.rotation_matrices(q[None, :])[0]
    assert np.abs(rot[2]).max() > 0.9999  # one body axis vertical
    assert t["ke"][-1] + t["rke"][-1] < 1e-10


# ---------------------------------------------------------------- time step, restart, output, errors


def test_critical_timestep_takes_the_smallest_curvature_radius(engine_run):
    a, b, c = 0.01, 0.006, 0.004
    scene = [domain(), material(rho=RHO), interaction(), model(), sq((0, 0, 0), (a, b, c), 2),
             sq((0.1, 0, 0), (0.005, 0.005, 0.005), 2, velocity=(0, 0, 1.0)),
             {"command": "get", "property": "critical_timestep"}]
    code, folder = engine_run(scene)
    assert code == 0
    line = [ln for ln in (folder / "log.dem").read_text().splitlines() if ln.startswith("critical_timestep:")][0]
    t_r = float(line.split("rayleigh_time = ")[1].split()[0])
    t_h = float(line.split("hertz_time = ")[1].split()[0])
    nu, y = 0.3, 1e7
    shear = y / (2 * (1 + nu))
    r_min = 2.0 / (a / b ** 2 + a / c ** 2)  # the ellipsoid's tip, smaller than the sphere's 5 mm
    assert t_r == pytest.approx(math.pi * r_min * math.sqrt(RHO / shear) / (0.1631 * nu + 0.8766), rel=1e-9)
    ystar = y / (2 * (1 - nu * nu))
    masses = [superquadrics.mass_properties(a, b, c, 2, 2, RHO)["mass"], RHO * 4 / 3 * math.pi * 0.005 ** 3]
    radii = [r_min, 0.005]
    expected = min(2.87 * (m * m / (0.5 * r * ystar * ystar * 2.0)) ** 0.2 for m, r in zip(masses, radii))
    assert t_h == pytest.approx(expected, rel=1e-9)


def test_restart_continues_bitwise(engine_run):
    bodies = [sq((0, 0, 0.006), (0.006, 0.005, 0.004), 4, velocity=(0.2, 0, -0.5), omega=(0, 3, 1)),
              sq((0.003, 0.001, 0.02), (0.005, 0.005, 0.004), [3, 6], velocity=(0, 0, -1.0))]
    cols = ["sq_x[1]", "sq_z[2]", "sq_qx[1]", "sq_omegay[2]"]
    base = _scene(bodies, [plane("floor", "z", 0.0)], steps=4000, every=4000, columns=cols)
    code, folder = engine_run(base, sub="long")
    assert code == 0, (folder / "log.dem").read_text()
    whole = (folder / "thermo.csv").read_text().splitlines()[-1]
    first = base[:-1] + [run(2000), {"command": "create", "object": "restart", "file": "half.npz"}]
    code, folder = engine_run(first, sub="a")
    assert code == 0, (folder / "log.dem").read_text()
    second = [material(rho=RHO), interaction(e=0.5, mu=0.3), model(),
              {"command": "set", "property": "restart", "file": str(folder / "half.npz")}, *gravity(),
              timestep(2e-6), thermo(2000, cols), run(2000)]
    code, folder = engine_run(second, sub="b")
    assert code == 0, (folder / "log.dem").read_text()
    assert (folder / "thermo.csv").read_text().splitlines()[-1] == whole


def test_vtk_output_has_a_point_per_body_with_orientation_and_shape(engine_run):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    bodies = [sq((0, 0, 0.02), (0.006, 0.005, 0.004), [4, 6], orientation={"axis": [0, 0, 1], "angle": 90}),
              sq((0.03, 0, 0.02), (0.005, 0.005, 0.005), 2)]
    scene = _scene(bodies, [plane("floor", "z", 0.0)], steps=10, every=10)
    scene.insert(-1, {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 10,
                      "folder": "post", "prefix": "dump"})
    scene.insert(-1, {"command": "fix", "name": "dump"})
    code, folder = engine_run(scene)
    assert code == 0, (folder / "log.dem").read_text()
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(folder / "post" / "dump_superquadrics_10.vtp"))
    reader.Update()
    data = reader.GetOutput()
    assert data.GetNumberOfPoints() == 2
    arrays = data.GetPointData()
    assert np.allclose(vtk_to_numpy(arrays.GetArray("half_axes"))[0], [0.006, 0.005, 0.004])
    assert np.allclose(vtk_to_numpy(arrays.GetArray("blockiness"))[0], [4, 6])
    axes = vtk_to_numpy(arrays.GetArray("axes"))[0].reshape(3, 3)
    assert np.allclose(axes[:, 0], [0, 0.006, 0], atol=1e-12)  # the a axis turned onto y


def test_sphere_kernels_hold_no_superquadric_code():
    source = generate_source(Combination(planes=True, gravity=True, tangential="history"))
    assert "superquadric" not in source and "sq_laws" not in source
    with_sq = generate_source(Combination(planes=True, gravity=True, tangential="history", superquadrics=True))
    assert "superquadric_pass" in with_sq
    assert "with superquadrics;" in with_sq.splitlines()[0]


@pytest.mark.parametrize("extra, message", [
    ({"command": "create", "object": "wall", "name": "drum", "shape": "cylinder", "radius": 0.05,
      "center": [0, 0], "type": 1}, "superquadrics touch planes and meshes only, not cylinder walls"),
    ({"command": "create", "object": "particle", "type": 1, "radius": 0.004, "position": [0.05, 0, 0]},
     "superquadrics do not touch spheres"),
])
def test_scenes_superquadrics_cannot_run_are_refused(engine_run, extra, message):
    scene = _scene([sq((0, 0, 0.02), (0.005, 0.005, 0.005), 2)], [extra], steps=10)
    code, folder = engine_run(scene)
    log = (folder / "log.dem").read_text()
    assert code != 0 and message in log


@pytest.mark.parametrize("field, value, message", [
    ("blockiness", 1.5, "field 'blockiness' must be a number or [n1, n2], each from 2 to 20"),
    ("blockiness", [2, 3, 4], "field 'blockiness'"),
    ("half_axes", [0.01, 0, 0.01], "field 'half_axes' must be three lengths > 0"),
])
def test_bad_shape_fields_name_the_field(engine_run, field, value, message):
    body = sq((0, 0, 0.02), (0.005, 0.005, 0.005), 2)
    body[field] = value
    code, folder = engine_run(_scene([body], steps=10))
    log = (folder / "log.dem").read_text()
    assert code != 0 and message in log
    assert json.loads((folder / "scene.json").read_text())  # the script is as written


def test_packing_settles_into_a_box_without_losing_a_body(engine_run):
    """superquadric_packing: 30 blocky ellipsoids (n = 4, half-axes 4, 2.5, 2 mm) at random positions and
    orientations from a seed, settling under gravity in a box of five planes: every body ends inside the box,
    above the floor by at least its smallest half-axis (less the overlap), and the pile comes to rest."""
    half = (0.004, 0.0025, 0.002)
    box = [plane("floor", "z", 0.0), plane("x0", "x", -0.02), plane("x1", "x", 0.02), plane("y0", "y", -0.02),
           plane("y1", "y", 0.02)]
    pack = {"command": "create", "object": "superquadric_packing", "type": 1, "half_axes": list(half),
            "blockiness": 4, "count": 30, "seed": 5,
            "region": {"shape": "box", "lo": [-0.02, -0.02, 0.0], "hi": [0.02, 0.02, 0.05]}}
    cols = [f"sq_{n}[{k}]" for k in range(1, 31) for n in ("x", "y", "z")]
    code, folder = engine_run(_scene([pack], box, mu=0.5, e=0.3, dt=1e-5, steps=40000, every=2000, columns=cols),
                              sub="pile")
    assert code == 0, (folder / "log.dem").read_text()
    t = read_csv(folder / "thermo.csv")
    assert t["atoms"][-1] == 30 and "created 30 superquadrics" in (folder / "log.dem").read_text()
    for k in range(1, 31):
        assert t[f"sq_z[{k}]"][-1] > 0.95 * min(half)
        assert abs(t[f"sq_x[{k}]"][-1]) < 0.02 and abs(t[f"sq_y[{k}]"][-1]) < 0.02
    assert t["ke"][-1] < 1e-3 * t["ke"].max() and t["ke"].max() > 1e-5
    # the same seed packs the same bodies
    code, again = engine_run(_scene([pack], box, steps=0, every=1, columns=cols[:3]), sub="again")
    assert code == 0 and read_csv(again / "thermo.csv")["sq_x[1]"][0] == t["sq_x[1]"][0]


# ---------------------------------------------------------------- mesh walls


def _write_stl(path, triangles):
    lines = ["solid test"]
    for t in np.asarray(triangles, dtype=np.float64):
        lines += [" facet normal 0 0 0", "  outer loop"] + [f"   vertex {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}" for v in t] + \
                 ["  endloop", " endfacet"]
    path.write_text("\n".join(lines + ["endsolid test", ""]))
    return str(path)


def _grid(x0, x1, y0, y1, cell):
    """A flat rectangle [x0, x1] x [y0, y1] at z = 0 as squares of side cell, each split into two triangles."""
    xs = np.linspace(x0, x1, round((x1 - x0) / cell) + 1)
    ys = np.linspace(y0, y1, round((y1 - y0) / cell) + 1)
    out = []
    for a in range(len(xs) - 1):
        for b in range(len(ys) - 1):
            p = [(xs[a], ys[b], 0.0), (xs[a + 1], ys[b], 0.0), (xs[a + 1], ys[b + 1], 0.0), (xs[a], ys[b + 1], 0.0)]
            out += [[p[0], p[1], p[2]], [p[0], p[2], p[3]]]
    return np.array(out)


def _mesh_wall(file):
    return {"command": "create", "object": "wall", "name": "floor", "shape": "mesh", "file": file, "type": 1}


@pytest.mark.parametrize("blockiness", [2, 5])
def test_body_on_a_mesh_floor_follows_the_plane(engine_run, tmp_path, blockiness):
    """A tilted, spinning body thrown onto a floor of 800 triangles (5 mm squares, smaller than the body: its
    contact crosses faces and their shared edges) moves as on the plane z = 0: face contacts have the
    plane's normal and depth, the flat edges between the triangles add nothing, history carries over."""
    floor = _write_stl(tmp_path / "floor.stl", _grid(-0.05, 0.05, -0.05, 0.05, 0.005))
    body = sq((0.001, 0.002, 0.011), (0.01, 0.006, 0.004), blockiness, velocity=(0.4, 0.1, -0.5),
              omega=(3, -8, 2), orientation={"axis": [1, 1, 0], "angle": 40})
    names = ["x", "y", "z", "vx", "vy", "vz", "lx", "ly", "lz"]
    cols = [f"sq_{n}[1]" for n in names] + ["wall_fx[floor]", "wall_fz[floor]"]  # and what the floor takes
    code, folder = engine_run(_scene([body], [plane("floor", "z", 0.0)], steps=40000, columns=cols), sub="plane")
    assert code == 0, (folder / "log.dem").read_text()
    want = read_csv(folder / "thermo.csv")
    code, folder = engine_run(_scene([body], [_mesh_wall(floor)], steps=40000, columns=cols), sub="mesh")
    assert code == 0, (folder / "log.dem").read_text()
    got = read_csv(folder / "thermo.csv")
    assert abs(want["sq_x[1]"][-1] - want["sq_x[1]"][0]) > 0.003  # it slid across triangles
    assert abs(want["sq_lx[1]"]).max() > 0  # and turned
    assert abs(want["wall_fz[floor]"]).max() > 0  # printed while touching
    for name in cols:
        scale = abs(want[name]).max()
        assert np.allclose(got[name], want[name], rtol=0, atol=1e-9 * scale), name


@pytest.mark.parametrize("theta", [35.0])
def test_ellipsoid_slides_down_an_inclined_mesh(engine_run, tmp_path, theta):
    """The incline of test_ellipsoid_on_an_incline_... as a mesh of 10 mm triangles along the body's path,
    turned by theta about y: the acceleration along it is g (sin theta - mu cos theta)."""
    mu = 0.5
    th = math.radians(theta)
    turn = np.array([[math.cos(th), 0, -math.sin(th)], [0, 1, 0], [math.sin(th), 0, math.cos(th)]])
    tris = _grid(-0.3, 0.05, -0.02, 0.02, 0.01) @ turn.T
    incline = _write_stl(tmp_path / "incline.stl", tris)
    normal = turn @ np.array([0, 0, 1.0])
    assert normal[0] == pytest.approx(-math.sin(th))
    centre = [(0.004 + 1e-5) * v for v in normal]
    body = sq(centre, (0.01, 0.006, 0.004), 2, orientation={"axis": [0, 1, 0], "angle": -theta})
    scene = _scene([body], [_mesh_wall(incline)], mu=mu, e=0.3, dt=1e-5, steps=50000, every=200,
                   columns=["sq_x[1]", "sq_z[1]", "sq_vx[1]", "sq_vz[1]"])
    code, folder = engine_run(scene, sub="incline")
    assert code == 0, (folder / "log.dem").read_text()
    time, s, late, acceleration, analytic = _downhill(folder, theta, mu)
    assert acceleration == pytest.approx(analytic, rel=0.03)
    assert s[-1] - s[0] > 0.03  # over several triangles


# ---------------------------------------------------------------- pair search


@pytest.mark.parametrize("count, spread", [(1, 0.01), (50, 0.01), (400, 0.05), (400, 1.0)])
def test_cell_grid_finds_every_pair_of_overlapping_bounding_spheres(count, spread):
    """The cell grid's candidates hold every pair j > i whose bounding spheres overlap (against all pairs), in
    increasing j; one body far away (a grid that would be huge) makes the cells larger, not the search wrong."""
    rng = np.random.default_rng(count)
    x = rng.uniform(0, spread, size=(count, 3))
    if count > 1:
        x[-1] = (50.0, -30.0, 80.0)
    radius = rng.uniform(0.001, 0.004, size=count)
    cell_start, order, cell_of, nc = superquadrics._cell_grid(x, radius)
    assert np.prod(nc) <= superquadrics.CELLS_PER_BODY * count + 27
    near = np.empty(count, dtype=np.int64)
    found = set()
    for i in range(count):
        k = superquadrics._neighbours(i, cell_start, order, cell_of, nc, near)
        assert np.all(np.diff(near[:k]) > 0) and np.all(near[:k] > i)
        found |= {(i, int(j)) for j in near[:k] if np.sum((x[i] - x[j]) ** 2) < (radius[i] + radius[j]) ** 2}
    want = {(i, j) for i in range(count) for j in range(i + 1, count)
            if np.sum((x[i] - x[j]) ** 2) < (radius[i] + radius[j]) ** 2}
    assert found == want
    assert count < 50 or spread > 0.05 or len(want) > 20  # the dense cases do have pairs
