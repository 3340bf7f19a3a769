"""Walls of any shape (engine/walls/, engine/mesh.py): planes with any normal, bounded planes, cylinders along
any axis with a turning surface, STL meshes that stand, translate or rotate.

Each check is against an analytic result or an independently computed value: the closest point of a triangle
against a formula of its own, a flat mesh against a plane (the same bytes, also for spheres sliding across
the triangles' edges and corners), a ridge and an apex against a plane (one contact, not two), a belt against
its rolling limit v = 2V/7, a paddle's first touch against its angle, rolling down an incline against
a = 5/7 g sin(theta), wall torques against r x F.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO, domain, engine_program, gravity, interaction, material, model, particle, plane, printer, \
    read_csv, run, timestep

G = 9.81


def write_stl(path, triangles, binary=False):
    """An STL file of triangles (m, 3, 3); binary files store float32, as the format does."""
    triangles = np.asarray(triangles, dtype=np.float64)
    if binary:
        import struct
        with open(path, "wb") as f:
            f.write(b"test".ljust(80, b" ") + struct.pack("<I", len(triangles)))
            for t in triangles:
                f.write(struct.pack("<12f", 0, 0, 0, *t.ravel()) + b"\0\0")
        return
    lines = ["solid test"]
    for t in triangles:
        lines += [" facet normal 0 0 0", "  outer loop"] + [f"   vertex {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}" for v in t] + \
                 ["  endloop", " endfacet"]
    path.write_text("\n".join(lines + ["endsolid test", ""]))


def grid(x0, x1, y0, y1, cells, z=0.0):
    """A flat rectangle at height z as cells x cells squares, each split into two triangles."""
    xs, ys = np.linspace(x0, x1, cells + 1), np.linspace(y0, y1, cells + 1)
    out = []
    for a in range(cells):
        for b in range(cells):
            p = [(xs[a], ys[b], z), (xs[a + 1], ys[b], z), (xs[a + 1], ys[b + 1], z), (xs[a], ys[b + 1], z)]
            out += [[p[0], p[1], p[2]], [p[0], p[2], p[3]]]
    return out


def drum(radius, half_length, facets):
    """The mantle of a drum along y (radius, y in [-half_length, half_length]) as facets x 2 triangles."""
    th = np.linspace(0, 2 * np.pi, facets + 1)
    ring = [(radius * math.cos(a), radius * math.sin(a)) for a in th]
    tris = []
    for (x0, z0), (x1, z1) in zip(ring[:-1], ring[1:]):
        p = [(x0, -half_length, z0), (x1, -half_length, z1), (x1, half_length, z1), (x0, half_length, z0)]
        tris += [[p[0], p[1], p[2]], [p[0], p[2], p[3]]]
    return tris


def mesh_wall(name, file, **extra):
    return {"command": "create", "object": "wall", "name": name, "shape": "mesh", "file": file, "type": 1, **extra}


def wall(name, shape, **fields):
    return {"command": "create", "object": "wall", "name": name, "shape": shape, "type": 1, **fields}


# ---------------------------------------------------------------- geometry

def reference_closest(p, tri):
    """Closest point of a triangle to p by a different route: the projection if it falls inside (barycentric
    coordinates by least squares), else the nearest of the three clamped segment projections."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    q = p - np.dot(p - a, n) * n
    lam = np.linalg.lstsq(np.column_stack([b - a, c - a]), q - a, rcond=None)[0]
    if lam.min() >= 0 and lam.sum() <= 1:
        return q
    best = None
    for u, v in ((a, b), (b, c), (c, a)):
        s = np.clip(np.dot(p - u, v - u) / np.dot(v - u, v - u), 0.0, 1.0)
        cand = u + s * (v - u)
        if best is None or np.linalg.norm(p - cand) < np.linalg.norm(p - best):
            best = cand
    return best


def test_closest_point_of_a_triangle_matches_an_independent_computation():
    from engine.mesh import closest_point

    rng = np.random.default_rng(4)
    regions = set()
    for _ in range(3000):
        tri = rng.normal(size=(3, 3))
        p = rng.normal(size=3) * 2.0
        cx, cy, cz, region = closest_point(p[0], p[1], p[2], tri[None], 0)
        regions.add(region)
        assert np.allclose([cx, cy, cz], reference_closest(p, tri), atol=1e-9)
    assert regions == set(range(7))  # the face, every edge and every corner were met


def test_stl_files_ascii_and_binary_load_placed(tmp_path):
    from engine.mesh import place, read_stl

    tri = np.array([[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.25, 0.0]]])
    write_stl(tmp_path / "a.stl", tri)
    write_stl(tmp_path / "b.stl", tri, binary=True)
    assert np.array_equal(read_stl(str(tmp_path / "a.stl")), read_stl(str(tmp_path / "b.stl")))
    placed = place(read_stl(str(tmp_path / "a.stl")), 2.0, ([0, 0, 1], 90.0), [1.0, 0.0, 0.0])
    assert np.allclose(placed[0], [[1, 0, 0], [1, 1, 0], [0.5, 0, 0]], atol=1e-12)


@pytest.mark.parametrize("content, message", [
    (None, "file 'm.stl' does not exist"),
    ("solid x\nnot an stl\n", "is not an STL file with triangles"),
    ("solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 2 0 0\n"
     "  endloop\n endfacet\nendsolid x\n", "has 1 triangle(s) of zero area"),
])
def test_bad_mesh_files_are_one_line_errors(tmp_path, content, message):
    if content is not None:
        (tmp_path / "m.stl").write_text(content)
    (tmp_path / "s.json").write_text(json.dumps([domain(), material(), mesh_wall("m", "m.stl")]))
    proc = subprocess.run([sys.executable, "-m", "engine", "-in", "s.json"], cwd=tmp_path, capture_output=True,
                          text=True, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}, timeout=300)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "field 'file'" in proc.stderr and message in proc.stderr, proc.stderr


@pytest.mark.parametrize("fields, message", [
    ({"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]}, "field 'normal' must be a direction"),
    ({"shape": "cylinder", "point": [0, 0, 0], "axis": "w", "radius": 1}, "field 'axis' must be one of x, y, z"),
    ({"shape": "cylinder", "point": [0, 0, 0], "axis": "x", "radius": 1, "extent": [1, 0]}, "field 'extent'"),
    ({"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "bounds": {"lo": [0, 0, 0]}},
     "field 'hi' is missing"),
])
def test_bad_wall_fields_are_one_line_errors(engine_run, fields, message):
    code, folder = engine_run([domain(), material(), wall("w", **fields)])
    assert code == 2
    assert message in (folder / "log.dem").read_text().splitlines()[-1]


# ---------------------------------------------------------------- a mesh is a wall like a plane

#: spheres thrown across a floor with friction: they slide and roll over many triangle edges and corners
def _floor_scene(floor):
    throws = [((-0.03, -0.02, 0.0051), (0.8, 0.45, 0.0)), ((0.02, 0.03, 0.02), (-0.6, -0.7, -0.3)),
              ((0.0, 0.0, 0.0049), (0.3, 0.3, 0.0)), ((-0.01, 0.03, 0.03), (0.5, -1.0, 0.0))]
    return [domain((-0.1, -0.1, -0.05), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.6, mu=0.4),
            model("hertz", "history"), floor] + gravity() + [
        particle(x, radius=0.005, velocity=v, omega=(0, 20.0, 0)) for x, v in throws] + [
        timestep(1e-5)] + printer(100, [f"{q}[{k}]" for k in range(1, 5) for q in ("x", "y", "z", "vx", "omegay")]) + [
        run(15000)]


def test_a_flat_mesh_is_the_plane_to_the_byte(engine_run):
    """128 triangles (dyadic coordinates, exact in single precision) against the plane z = 0: the same bytes,
    although the spheres cross dozens of triangle edges and corners (one contact per touched point, the shear
    history handed on to the next triangle of the same plane)."""
    write_stl(engine_run.folder / "floor.stl", grid(-0.0625, 0.0625, -0.0625, 0.0625, 8))
    code, plain = engine_run(_floor_scene(plane("floor", "z", 0.0)), sub="plane")
    assert code == 0
    code, meshed = engine_run(_floor_scene(mesh_wall("floor", "../floor.stl")), sub="mesh")
    assert code == 0, (meshed / "log.dem").read_text()[-500:]
    a, b = (plain / "series.csv").read_bytes(), (meshed / "series.csv").read_bytes()
    series = read_csv(meshed / "series.csv")
    assert a == b
    assert np.ptp(series["x[1]"]) > 0.03 and np.ptp(series["y[4]"]) > 0.03  # they travelled across triangles


@pytest.mark.parametrize("shape", ["ridge", "apex"])
def test_a_convex_edge_or_corner_pushes_once(engine_run, shape):
    """A sphere dropped onto the ridge of a roof (two slopes of two triangles each) or the apex of a pyramid
    touches one edge or corner of several triangles: one contact, the bounce of a plane through that point."""
    h = 0.0625
    if shape == "ridge":
        tris = [[(0, -h, 0), (h, -h, -h), (h, h, -h)], [(0, -h, 0), (h, h, -h), (0, h, 0)],
                [(0, -h, 0), (0, h, 0), (-h, h, -h)], [(0, -h, 0), (-h, h, -h), (-h, -h, -h)]]
    else:
        tris = [[(0, 0, 0), (h, -h, -h), (h, h, -h)], [(0, 0, 0), (h, h, -h), (-h, h, -h)],
                [(0, 0, 0), (-h, h, -h), (-h, -h, -h)], [(0, 0, 0), (-h, -h, -h), (h, -h, -h)]]
    write_stl(engine_run.folder / "roof.stl", tris)

    def scene(ground):
        return [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.7, mu=0.0),
                model("hertz", "history"), ground] + gravity() + [
            particle((0, 0.01 if shape == "ridge" else 0, 0.02), radius=0.005), timestep(1e-5)] + printer(
            50, ["z[1]", "vz[1]", "x[1]", "fz[1]"]) + [run(12000)]

    code, flat = engine_run(scene(plane("ground", "z", 0.0)), sub="plane")
    code2, roof = engine_run(scene(mesh_wall("ground", "../roof.stl")), sub="roof")
    assert code == code2 == 0
    a, b = read_csv(flat / "series.csv"), read_csv(roof / "series.csv")
    assert np.max(a["vz[1]"]) > 0.3  # it bounced
    np.testing.assert_allclose(b["z[1]"], a["z[1]"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b["vz[1]"], a["vz[1]"], rtol=1e-9, atol=1e-12)
    assert np.all(b["x[1]"] == 0.0)


def test_a_sphere_beside_a_convex_edge_feels_only_the_face(engine_run):
    """At rest on the top face of a block, 0.03 r from its edge: the edge is nearer than r (by 1e-5 m once the
    weight presses the sphere 1.35e-5 m into the face) but is not the closest point of the surface; a false edge
    contact would push the sphere sideways."""
    a = 0.0625
    box = [[(-a, -a, 0), (0, -a, 0), (0, a, 0)], [(-a, -a, 0), (0, a, 0), (-a, a, 0)],      # top, z = 0, x <= 0
           [(0, -a, 0), (0, -a, -a), (0, a, -a)], [(0, -a, 0), (0, a, -a), (0, a, 0)]]     # side, x = 0
    write_stl(engine_run.folder / "block.stl", box)
    r = 0.005
    scene = [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.3, mu=0.5),
             model("hertz", "history"), mesh_wall("block", "block.stl")] + gravity() + [
        particle((-0.03 * r, 0, r), radius=r), timestep(1e-5)] + printer(100, ["x[1]", "z[1]", "fx[1]"]) + [
        run(5000)]
    code, folder = engine_run(scene)
    assert code == 0
    series = read_csv(folder / "series.csv")
    edge = np.hypot(series["x[1]"], series["z[1]"])
    assert edge.min() < r  # the edge is within reach
    assert np.all(series["fx[1]"] == 0.0) and np.all(series["x[1]"] == -0.03 * r)


# ---------------------------------------------------------------- moving walls

def test_a_moving_belt_mesh_is_the_moving_plane_and_rolls_the_sphere_at_two_sevenths(engine_run):
    """A flat mesh translating at V along x (a belt) under a sphere at rest: friction brings it to rolling
    without slip, v = 2V/7 (impulse J: m v = J, I w = J r, v + w r = V, I = 0.4 m r^2). The plane that moves
    in its own plane at V gives the same bytes."""
    V = 0.7
    write_stl(engine_run.folder / "belt.stl", grid(-0.25, 0.25, -0.0625, 0.0625, 4))

    def scene(belt):
        return [domain((-0.3, -0.1, -0.05), (0.3, 0.1, 0.1)), material(y=5e6), interaction(e=0.5, mu=0.5),
                model("hertz", "history"), belt] + gravity() + [
            particle((0.0, 0.0, 0.005), radius=0.005), timestep(1e-5)] + printer(
            100, ["x[1]", "vx[1]", "omegay[1]"]) + [run(8000)]

    code, moving_plane = engine_run(scene(plane("belt", "z", 0.0, velocity=(V, 0, 0))), sub="plane")
    code2, moving_mesh = engine_run(scene(mesh_wall("belt", "../belt.stl", velocity=[V, 0, 0])), sub="mesh")
    assert code == code2 == 0
    assert (moving_plane / "series.csv").read_bytes() == (moving_mesh / "series.csv").read_bytes()
    series = read_csv(moving_mesh / "series.csv")
    assert series["vx[1]"][-1] == pytest.approx(2 * V / 7, rel=2e-3)


def test_a_rotating_paddle_touches_the_sphere_when_its_angle_says(engine_run):
    """A vertical paddle (two triangles along +x, from r = 0.02 to 0.08 m) turning about z at omega reaches a
    resting sphere of radius r at (0, 0.05): first touch when 0.05 cos(theta) = r, t = acos(r/0.05)/omega."""
    omega, r, dt = 2.0, 0.004, 1e-5
    paddle = [[(0.02, 0, -0.02), (0.08, 0, -0.02), (0.08, 0, 0.02)], [(0.02, 0, -0.02), (0.08, 0, 0.02), (0.02, 0, 0.02)]]
    write_stl(engine_run.folder / "paddle.stl", paddle)
    scene = [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.5, mu=0.0),
             model("hertz", "history"),
             mesh_wall("paddle", "paddle.stl", rotation={"point": [0, 0, 0], "axis": "z", "angular_velocity": omega}),
             particle((0.0, 0.05, 0.0), radius=r), timestep(dt), run(int(0.7 / dt))] + printer(
        1, ["fx[1]", "fy[1]", "wall_fx[paddle]"]) + [run(int(0.1 / dt))]
    code, folder = engine_run(scene)
    assert code == 0, (folder / "log.dem").read_text()[-500:]
    series = read_csv(folder / "series.csv")
    touched = np.nonzero(np.hypot(series["fx[1]"], series["fy[1]"]) > 0)[0]
    assert len(touched)
    expected = math.acos(r / 0.05) / omega
    assert series["time"][touched[0]] == pytest.approx(expected, abs=1.5 * dt)
    assert series["fx[1]"][touched[0]] < 0  # the paddle comes from +x, turning counter-clockwise
    assert series["wall_fx[paddle]"][touched[0]] == pytest.approx(-series["fx[1]"][touched[0]], rel=1e-12)


def test_wall_force_and_torque_of_a_resting_sphere_are_its_weight_and_r_cross_f(engine_run):
    """A sphere settled on a mesh floor at (a, b): force on the wall (0, 0, -m g), torque about the wall's
    rotation point p, (c - p) x F, with c = (a, b, 0) the contact point."""
    a, b, r, rho = 0.021, -0.013, 0.005, 2500.0
    p = (0.01, 0.02, 0.0)
    write_stl(engine_run.folder / "floor.stl", grid(-0.0625, 0.0625, -0.0625, 0.0625, 2))
    names = ["wall_fx[floor]", "wall_fy[floor]", "wall_fz[floor]", "wall_tx[floor]", "wall_ty[floor]",
             "wall_tz[floor]"]
    scene = [domain((-0.1, -0.1, -0.05), (0.1, 0.1, 0.1)), material(y=5e6, rho=rho), interaction(e=0.1, mu=0.5),
             model("hertz", "history"),
             mesh_wall("floor", "floor.stl", rotation={"point": list(p), "axis": "z", "angular_velocity": 0.0}),
             ] + gravity() + [particle((a, b, r), radius=r), timestep(1e-5)] + printer(1000, names) + [run(40000)]
    code, folder = engine_run(scene)
    assert code == 0
    last = {k: v[-1] for k, v in read_csv(folder / "series.csv").items()}
    weight = rho * 4 / 3 * math.pi * r ** 3 * G
    force = np.array([0, 0, -weight])
    torque = np.cross(np.array([a, b, 0.0]) - np.array(p), force)
    np.testing.assert_allclose([last[n] for n in names[:3]], force, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose([last[n] for n in names[3:]], torque, rtol=1e-6, atol=1e-12)


# ---------------------------------------------------------------- planes with any normal, bounded planes

@pytest.mark.parametrize("mu, factor", [(0.0, 1.0), (0.8, 5.0 / 7.0)])
def test_down_an_inclined_plane(engine_run, mu, factor):
    """A sphere released on a plane tilted by theta about y (normal (sin theta, 0, cos theta)): it slides (mu = 0, a = g sin theta) or rolls
    without slip (a = 5/7 g sin theta); distance along the slope s = a t^2 / 2."""
    theta, r, dt, steps = math.radians(20), 0.005, 1e-5, 20000
    n = [math.sin(theta), 0.0, math.cos(theta)]
    start = [r * n[0], 0.0, r * n[2]]  # touching the plane through the origin
    scene = [domain((-0.5, -0.1, -0.5), (0.5, 0.1, 0.5)), material(y=5e6), interaction(e=0.5, mu=mu),
             model("hertz", "history"), wall("slope", "plane", point=[0, 0, 0], normal=n)] + gravity() + [
        particle(start, radius=r), timestep(dt)] + printer(steps, ["x[1]", "z[1]"]) + [run(steps)]
    code, folder = engine_run(scene)
    assert code == 0
    end = read_csv(folder / "series.csv")
    travelled = math.hypot(end["x[1]"][-1] - start[0], end["z[1]"][-1] - start[2])  # along the slope
    t = steps * dt
    assert end["x[1]"][-1] > start[0]  # downhill: the plane falls towards +x
    assert travelled == pytest.approx(0.5 * factor * G * math.sin(theta) * t * t, rel=3e-3)


def test_a_bounded_plane_catches_only_what_falls_on_it(engine_run):
    scene = [domain((-0.2, -0.2, -0.2), (0.2, 0.2, 0.2)), material(y=5e6), interaction(e=0.5),
             model("hertz", "history"),
             wall("tray", "plane", point=[0, 0, 0], normal=[0, 0, 1], bounds={"lo": [-0.05, -0.05, -1], "hi": [0.05, 0.05, 1]})
             ] + gravity() + [particle((0.0, 0, 0.02), radius=0.005), particle((0.1, 0, 0.02), radius=0.005),
                              timestep(1e-5)] + printer(1000, ["z[1]", "z[2]"]) + [run(15000)]
    code, folder = engine_run(scene)
    assert code == 0
    z = read_csv(folder / "series.csv")
    assert z["z[1]"].min() > 0.004  # caught
    assert z["z[2]"][-1] < -0.05    # fell past the tray's edge


# ---------------------------------------------------------------- cylinders along any axis, turning

def test_a_cylinder_along_x_is_the_z_cylinder_with_the_axes_renamed(engine_run):
    """The same sphere in a cylinder along z (gravity -x) and along x (gravity -y), coordinates renamed
    (x, y, z) -> (y, z, x): the same trajectory to round-off."""
    def scene(axis_fields, g, start, v):
        return [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.6, mu=0.3),
                model("hertz", "history"), wall("pipe", "cylinder", radius=0.04, **axis_fields)] + gravity(g) + [
            particle(start, radius=0.005, velocity=v), timestep(1e-5)] + printer(
            200, ["x[1]", "y[1]", "z[1]"]) + [run(20000)]

    code, along_z = engine_run(scene({"center": [0, 0]}, (-G, 0, 0), (0.01, 0.02, 0.003), (0.2, -0.3, 0.1)), sub="z")
    code2, along_x = engine_run(scene({"point": [0, 0, 0], "axis": "x"}, (0, -G, 0), (0.003, 0.01, 0.02),
                                      (0.1, 0.2, -0.3)), sub="x")
    assert code == code2 == 0
    a, b = read_csv(along_z / "series.csv"), read_csv(along_x / "series.csv")
    for za, xb in (("x[1]", "y[1]"), ("y[1]", "z[1]"), ("z[1]", "x[1]")):
        np.testing.assert_allclose(b[xb], a[za], rtol=0, atol=1e-9)


@pytest.mark.slow
def test_a_turning_cylinder_drags_the_bed_like_a_turning_faceted_mesh(engine_run):
    """A drum along y turning at 3 rad/s: the analytic cylinder and an STL drum of 360 facets rotating as a
    mesh lift the bed alike (the bed's centre of mass moves against the turn: -x for +omega about +y)."""
    R, L = 0.05, 0.0125
    write_stl(engine_run.folder / "drum.stl", drum(R, L, 360))

    def scene(drum):
        return [domain((-0.06, -0.02, -0.06), (0.06, 0.02, 0.06)), material(y=5e6),
                interaction(e=0.5, mu=0.5), model("hertz", "history"), drum,
                wall("front", "plane", point=[0, -L, 0], normal=[0, 1, 0]),
                wall("back", "plane", point=[0, L, 0], normal=[0, 1, 0])] + gravity() + [
            {"command": "create", "object": "lattice", "type": 1, "radius": 0.003, "spacing": 0.0062,
             "region": {"shape": "box", "lo": [-0.025, -L, -0.04], "hi": [0.025, L, -0.01]}},
            timestep(2e-5), {"command": "set", "property": "thermo", "every": 2500, "columns": ["com_x", "com_z"]},
            run(40000)]

    code, cylinder = engine_run(scene(wall("drum", "cylinder", point=[0, 0, 0], axis="y", radius=R,
                                           angular_velocity=3.0)), sub="cylinder")
    code2, faceted = engine_run(scene(mesh_wall("drum", "../drum.stl", rotation={"axis": "y", "angular_velocity": 3.0})),
                                sub="mesh")
    assert code == code2 == 0
    a, b = read_csv(cylinder / "thermo.csv"), read_csv(faceted / "thermo.csv")
    late = a["step"] >= 20000
    assert a["com_x"][late].mean() < -0.004  # lifted against the turn
    assert b["com_x"][late].mean() == pytest.approx(a["com_x"][late].mean(), rel=0.15)


# ---------------------------------------------------------------- memory, restart, threads

def test_mesh_contact_history_is_sparse():
    """1,000 particles over a mesh of 20,000 triangles: the list holds the triangles near each particle, not
    particles x triangles."""
    from engine import state
    from engine.mesh import empty_mesh_list, mesh_rebuild

    tris = np.array(grid(-0.5, 0.5, -0.5, 0.5, 100), dtype=np.float64)
    rng = np.random.default_rng(2)
    n = 1000
    s = state.append(state.empty(), x=np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(0.0, 0.004, n)]),
                     radius=np.full(n, 0.004), pid=np.arange(1, n + 1))
    lst = mesh_rebuild(s, n, empty_mesh_list(0, 3), tris, 0.001)
    assert lst.hist.shape[0] == len(lst.tri) < 20 * n
    near = [int(t) for t in lst.tri[lst.start[0]:lst.start[1]]]
    assert near  # particle 0 has its triangles listed; each is within r + skin
    from engine.mesh import triangle_distance
    assert all(triangle_distance(*s.x[0], tris, t) < 0.005 for t in near)


def test_mesh_list_is_every_triangle_within_reach_in_increasing_order():
    """The sparse list of each particle (a cell grid of the triangles, one distance test per listed
    triangle) against all triangles tested: exactly those within r + skin, in increasing order, none for a
    particle outside the grid."""
    from engine import state
    from engine.mesh import empty_mesh_list, mesh_rebuild, triangle_distance

    tris = np.concatenate([np.array(drum(0.04, 0.01, 24), dtype=np.float64),
                           np.array(grid(-0.05, 0.05, -0.05, 0.05, 6, z=-0.045), dtype=np.float64)])
    rng = np.random.default_rng(3)
    n = 400
    x = np.column_stack([rng.uniform(-0.05, 0.05, n), rng.uniform(-0.015, 0.015, n), rng.uniform(-0.05, 0.05, n)])
    x[0] = [1.0, 1.0, 1.0]  # far outside the grid
    radius = rng.uniform(0.001, 0.003, n)
    s = state.append(state.empty(), x=x, radius=radius, pid=np.arange(1, n + 1))
    skin = 0.001
    lst = mesh_rebuild(s, n, empty_mesh_list(0, 3), tris, skin)
    listed = 0
    for i in range(n):
        expected = [t for t in range(len(tris)) if triangle_distance(*x[i], tris, t) < radius[i] + skin]
        assert lst.tri[lst.start[i]:lst.start[i + 1]].tolist() == expected, i
        listed += len(expected)
    assert listed > n // 4 and lst.start[1] == 0


def test_placed_meshes_turn_each_about_its_own_axis():
    """place_vertices with two meshes (their triangles in runs, one mesh in two runs): each corner is
    R(angle) (v0 - p) + p + shift of its own mesh, the normal its triangle's, against rotation matrices."""
    from engine.mesh import normals, place_vertices, rotation_matrix

    rng = np.random.default_rng(4)
    tri_v0 = rng.uniform(-0.05, 0.05, (9, 3, 3))
    tri_mesh = np.array([0, 0, 1, 1, 1, 0, 0, 1, 1], dtype=np.int64)
    point0 = np.array([[0.01, 0.0, -0.02], [0.0, 0.03, 0.0]])
    axis = np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    angle = np.array([0.7, -2.1])
    shift = np.array([[0.0, 0.001, 0.0], [0.002, 0.0, -0.003]])
    tri_v = np.empty_like(tri_v0)
    tri_n = np.empty((9, 3))
    place_vertices(tri_v0, tri_mesh, point0, axis, angle, shift, tri_v, tri_n, np.bool_(True))
    for t, m in enumerate(tri_mesh):
        expected = (tri_v0[t] - point0[m]) @ rotation_matrix(axis[m], angle[m]).T + point0[m] + shift[m]
        assert tri_v[t] == pytest.approx(expected, abs=1e-15)
    assert tri_n == pytest.approx(normals(tri_v), abs=1e-14)
    place_vertices(tri_v0, tri_mesh, point0, axis, angle, shift, tri_v, tri_n, np.bool_(False))
    assert tri_v == pytest.approx(tri_v0 + shift[tri_mesh][:, None, :], abs=1e-15)


def _drum_program(folder, steps, restart_at=None, threads=1):
    """The rotating mesh drum as a program (a restart written at restart_at and a continuation read from it)."""
    L = 0.01
    folder.mkdir(parents=True, exist_ok=True)
    write_stl(folder / "drum.stl", drum(0.04, L, 24))
    head = [domain((-0.05, -0.02, -0.05), (0.05, 0.02, 0.05)), material(y=5e6), interaction(e=0.5, mu=0.5),
            model("hertz", "history"),
            mesh_wall("drum", "drum.stl", rotation={"axis": "y", "angular_velocity": 4.0}),
            wall("front", "plane", point=[0, -L, 0], normal=[0, 1, 0]),
            wall("back", "plane", point=[0, L, 0], normal=[0, 1, 0])] + gravity()
    body = [{"command": "create", "object": "lattice", "type": 1, "radius": 0.003, "spacing": 0.0065,
             "region": {"shape": "box", "lo": [-0.025, -L, -0.035], "hi": [0.025, L, -0.005]}}, timestep(2e-5)]
    out = printer(500, ["x[5]", "z[5]", "vx[30]", "omegay[30]", "wall_ty[drum]"])
    if restart_at is None:
        scripts = {"scene.json": head + body + out + [run(steps)]}
    else:
        scripts = {"first.json": head + body + [run(restart_at), {"command": "create", "object": "restart",
                                                                  "file": "r.npz"}],
                   "scene.json": head + [{"command": "set", "property": "restart", "file": "r.npz"}] + out + [
                       run(steps - restart_at)]}
    for name, script in scripts.items():
        proc = engine_program(folder, script, "-threads", str(threads), name=name)
        assert proc.returncode == 0, proc.stdout[-1500:] + proc.stderr[-1500:]
    return read_csv(folder / "series.csv")


@pytest.mark.slow
def test_a_rotating_mesh_drum_gives_the_same_bytes_on_two_threads_and_after_a_restart(tmp_path):
    one = _drum_program(tmp_path / "one", 3000)
    _drum_program(tmp_path / "two", 3000, threads=2)
    assert (tmp_path / "one" / "series.csv").read_bytes() == (tmp_path / "two" / "series.csv").read_bytes()
    assert np.ptp(one["omegay[30]"]) > 0  # the drum turned the bed
    continued = _drum_program(tmp_path / "continued", 3000, restart_at=1500)
    late = one["step"] >= 1500
    for name in ("x[5]", "z[5]", "vx[30]", "omegay[30]"):
        assert np.array_equal(continued[name], one[name][late]), name


def test_insertion_never_places_a_sphere_into_a_wall(engine_run):
    """An insertion region that a tilted plane and a mesh cut through: no inserted sphere overlaps either."""
    tris = grid(-0.05, 0.05, -0.05, 0.05, 4, z=0.02)
    write_stl(engine_run.folder / "shelf.stl", tris)
    scene = [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(y=5e6), interaction(e=0.5),
             model("hertz", "history"), mesh_wall("shelf", "shelf.stl"),
             wall("slope", "plane", point=[0, 0, 0], normal=[1, 0, 1])] + [
        {"command": "create", "object": "modifier", "name": "feed", "kind": "insert", "every": 10, "type": 1,
         "rate": 2e7, "total": 400, "radius": 0.003, "seed": 3,
         "region": {"shape": "box", "lo": [-0.05, -0.05, 0.0], "hi": [0.05, 0.05, 0.04]}},
        {"command": "fix", "name": "feed"}, timestep(1e-6),
        {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 10},
        {"command": "fix", "name": "dump"}, run(10)]
    code, folder = engine_run(scene)
    assert code == 0, (folder / "log.dem").read_text()[-800:]
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(folder / "post" / "particles_0.vtp"))
    reader.Update()
    x = vtk_to_numpy(reader.GetOutput().GetPoints().GetData())
    assert len(x) > 50
    assert np.all(np.abs(x[:, 2] - 0.02) >= 0.003)  # clear of the shelf
    assert np.all(np.abs(x[:, 0] + x[:, 2]) / math.sqrt(2) >= 0.003)  # clear of the slope
