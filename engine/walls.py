"""The wall set: every wall of a scene as one object of arrays, passed whole to compiled code.

Walls come in three shapes, in this order (a wall's index in `WallSet.force`, `WallSet.torque` and the
particles' dense wall history is its place in it): planes, cylinders, meshes.

- plane: a point and a unit normal (any direction), two-sided, optionally bounded to a box the contact point
  must lie in, moving at a velocity (the point moves with its whole velocity; the part along the plane only
  shears the contacts).
- cylinder: a point on its axis, the unit axis, a radius, contact inside or outside, optionally limited to an
  extent along the axis; its surface may turn about the axis at an angular velocity (a drum): the shape stays,
  the surface moves at omega R tangentially.
- mesh: triangles from an STL file (`engine.mesh`), moving at a velocity and/or rotating about an axis through a
  point; its contacts and their history live in a sparse per-particle list (`engine.mesh.MeshList`).

Wall definitions as the script gives them stay plain dicts (JSON in restart files); what moves is held by the
Simulation as arrays (plane points, mesh angles and shifts) that the compiled step loop advances in place.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from . import mesh as meshes

SHAPES = ("plane", "cylinder", "mesh")

#: planes: point (m, 3, moves), unit normal, velocity (m/s, 3), type (0-based), bounds lo/hi of the contact
#: point (m, 3; +-inf when unbounded). cylinders: point on the axis (m, 3), unit axis, radius (m), side (+1
#: inside, -1 outside), angular velocity of the surface about the axis (rad/s), extent lo/hi along the axis
#: (m, from the point), type. meshes: reference corners (m, 3, 3), current corners and unit normals, mesh of
#: each triangle, vertex ids, flat edges and corners (engine.mesh.flat_parts) and vertex -> triangles (fan) of
#: the topology; per mesh: type, velocity (m/s),
#: rotation point at the start (m), unit rotation axis, angular velocity (rad/s), angle turned (rad) and
#: shift (m) so far, how far (m) its farthest corner moves per unit time (for the rebuild criterion), the
#: wall index of its first mesh; travel (1): how far meshes may have moved since the last rebuild (m).
#: force, torque: force (N) and torque about the origin (N m) the particles exert on each wall, at the last
#: step of a chunk.
WALL_FIELDS = ("plane_point", "plane_normal", "plane_vel", "plane_type", "plane_lo", "plane_hi",
               "cyl_point", "cyl_axis", "cyl_radius", "cyl_side", "cyl_omega", "cyl_lo", "cyl_hi", "cyl_type",
               "tri_v0", "tri_v", "tri_n", "tri_mesh", "tri_vid", "tri_flat", "fan_start", "fan_tri",
               "mesh_type", "mesh_vel", "mesh_point0", "mesh_axis", "mesh_omega", "mesh_angle", "mesh_shift",
               "mesh_speed", "mesh_wall0", "travel", "force", "torque")
WallSet = namedtuple("WallSet", WALL_FIELDS)


def ordered(walls: list[dict]) -> list[dict]:
    """Planes first, then cylinders, then meshes (the order of the wall history columns and of WallSet.force)."""
    return [w for shape in SHAPES for w in walls if w["shape"] == shape]


def of_shape(walls: list[dict], shape: str) -> list[dict]:
    return [w for w in walls if w["shape"] == shape]


def dense_count(walls: list[dict]) -> int:
    """Walls whose contact history each particle keeps densely (planes and cylinders; meshes keep theirs in
    the sparse list)."""
    return sum(1 for w in walls if w["shape"] != "mesh")


def _bounds(w, key, default):
    b = w.get("bounds")
    return b[key] if b else [default] * 3


def mesh_arrays(walls: list[dict], triangles: dict) -> dict:
    """The meshes' triangle arrays (reference corners, mesh index, topology over all meshes)."""
    mesh_walls = of_shape(walls, "mesh")
    parts = [triangles[w["name"]] for w in mesh_walls]
    tri_v0 = np.ascontiguousarray(np.concatenate(parts)) if parts else np.zeros((0, 3, 3))
    tri_mesh = np.concatenate([np.full(len(p), k, dtype=np.int64) for k, p in enumerate(parts)]) if parts \
        else np.zeros(0, dtype=np.int64)
    if parts:
        # topology per mesh (two meshes never share a vertex, even where they touch), numbered globally
        vids, flats, fan_starts, fan_tris, first, vertices = [], [], [np.zeros(1, dtype=np.int64)], [], 0, 0
        for p in parts:
            vid, fan_start, fan_tri = meshes.topology(p, first)
            flats.append(meshes.flat_parts(vid, meshes.normals(p)))
            vids.append(vid + vertices)
            fan_starts.append(fan_start[1:] + fan_starts[-1][-1])
            fan_tris.append(fan_tri)
            first += len(p)
            vertices += len(fan_start) - 1
        tri_vid = np.concatenate(vids)
        tri_flat = np.concatenate(flats)
        fan_start = np.concatenate(fan_starts)
        fan_tri = np.concatenate(fan_tris)
    else:
        tri_vid, fan_start, fan_tri = np.zeros((0, 3), dtype=np.int64), np.zeros(1, dtype=np.int64), \
            np.zeros(0, dtype=np.int64)
        tri_flat = np.zeros((0, 6), dtype=np.uint8)
    return dict(tri_v0=tri_v0, tri_mesh=tri_mesh, tri_vid=tri_vid, tri_flat=tri_flat, fan_start=fan_start,
                fan_tri=fan_tri)


def rotation_of(w) -> tuple:
    """(point m, unit axis, angular velocity rad/s) of a mesh's rotation; the origin and no turn without one."""
    rot = w.get("rotation")
    if not rot:
        return [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.0
    return rot["point"], rot["axis"], rot["angular_velocity"]


def wall_set(sim) -> WallSet:
    """The arrays of sim's walls (already ordered); sim's plane points, mesh angles and shifts, wall forces and
    torques are used as they are (they carry state between runs)."""
    walls = sim.walls
    planes, cylinders, mesh_walls = (of_shape(walls, s) for s in SHAPES)
    m = mesh_arrays(walls, sim.mesh_triangles)
    rotations = [rotation_of(w) for w in mesh_walls]
    mesh_point0 = np.array([r[0] for r in rotations], dtype=np.float64).reshape(-1, 3)
    mesh_axis = np.array([r[1] for r in rotations], dtype=np.float64).reshape(-1, 3)
    mesh_omega = np.array([r[2] for r in rotations], dtype=np.float64)
    mesh_vel = np.array([w["velocity"] for w in mesh_walls], dtype=np.float64).reshape(-1, 3)
    speed = np.array([mesh_speed(w, sim.mesh_triangles[w["name"]]) for w in mesh_walls], dtype=np.float64)
    tri_v = np.empty_like(m["tri_v0"])
    tri_n = np.empty((len(tri_v), 3))
    if len(tri_v):
        meshes.place_vertices(m["tri_v0"], m["tri_mesh"], mesh_point0, mesh_axis, sim.mesh_angle, sim.mesh_shift,
                              tri_v, tri_n, bool(np.any(mesh_omega != 0.0)))
    return WallSet(
        plane_point=sim.plane_point,
        plane_normal=np.array([w["normal"] for w in planes], dtype=np.float64).reshape(-1, 3),
        plane_vel=np.array([w["velocity"] for w in planes], dtype=np.float64).reshape(-1, 3),
        plane_type=np.array([w["type"] - 1 for w in planes], dtype=np.int64),
        plane_lo=np.array([_bounds(w, "lo", -np.inf) for w in planes], dtype=np.float64).reshape(-1, 3),
        plane_hi=np.array([_bounds(w, "hi", np.inf) for w in planes], dtype=np.float64).reshape(-1, 3),
        cyl_point=np.array([w["point"] for w in cylinders], dtype=np.float64).reshape(-1, 3),
        cyl_axis=np.array([w["axis"] for w in cylinders], dtype=np.float64).reshape(-1, 3),
        cyl_radius=np.array([w["radius"] for w in cylinders], dtype=np.float64),
        cyl_side=np.array([1.0 if w["side"] == "inside" else -1.0 for w in cylinders], dtype=np.float64),
        cyl_omega=np.array([w["angular_velocity"] for w in cylinders], dtype=np.float64),
        cyl_lo=np.array([(w["extent"] or [-np.inf, np.inf])[0] for w in cylinders], dtype=np.float64),
        cyl_hi=np.array([(w["extent"] or [-np.inf, np.inf])[1] for w in cylinders], dtype=np.float64),
        cyl_type=np.array([w["type"] - 1 for w in cylinders], dtype=np.int64),
        tri_v0=m["tri_v0"], tri_v=tri_v, tri_n=tri_n, tri_mesh=m["tri_mesh"], tri_vid=m["tri_vid"],
        tri_flat=m["tri_flat"],
        fan_start=m["fan_start"], fan_tri=m["fan_tri"],
        mesh_type=np.array([w["type"] - 1 for w in mesh_walls], dtype=np.int64),
        mesh_vel=mesh_vel, mesh_point0=mesh_point0, mesh_axis=mesh_axis, mesh_omega=mesh_omega,
        mesh_angle=sim.mesh_angle, mesh_shift=sim.mesh_shift, mesh_speed=speed,
        mesh_wall0=np.array([len(planes) + len(cylinders)], dtype=np.int64),
        travel=sim.mesh_travel, force=sim.wall_force, torque=sim.wall_torque)


def features(walls: list[dict]) -> dict:
    """Which wall code a scene needs compiled (engine.kernels.Combination fields)."""
    planes, cylinders, mesh_walls = (of_shape(walls, s) for s in SHAPES)
    return dict(planes=bool(planes), bounded_planes=any(w.get("bounds") for w in planes),
                cylinders=bool(cylinders), cylinder_spin=any(w["angular_velocity"] != 0.0 for w in cylinders),
                cylinder_extent=any(w["extent"] for w in cylinders), meshes=bool(mesh_walls),
                mesh_motion=any(any(w["velocity"]) or w.get("rotation") for w in mesh_walls),
                mesh_rotation=any(w.get("rotation") for w in mesh_walls))


def reference_points(sim, walls_set: WallSet | None = None) -> np.ndarray:
    """(walls, 3) the point each wall's torque is taken about (m): a plane's current point, a cylinder's axis
    point, a mesh's rotation point (the origin without a rotation), moved with the mesh."""
    planes, cylinders, mesh_walls = (of_shape(sim.walls, s) for s in SHAPES)
    rows = [p for p in sim.plane_point] + [np.asarray(w["point"], float) for w in cylinders]
    rows += [np.asarray(rotation_of(w)[0], float) + sim.mesh_shift[k] for k, w in enumerate(mesh_walls)]
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def mesh_speed(w: dict, triangles: np.ndarray) -> float:
    """The fastest corner of a mesh (m/s): |v| + |omega| x (largest distance of a corner from its axis)."""
    point, axis, omega = rotation_of(w)
    corners = triangles.reshape(-1, 3) - np.asarray(point, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    radial = corners - np.outer(corners @ axis, axis)
    reach = float(np.sqrt(np.max(np.einsum("ij,ij->i", radial, radial)))) if len(corners) else 0.0
    return float(np.linalg.norm(w["velocity"])) + abs(omega) * reach


def surface_speeds(sim) -> list:
    """The largest speed (m/s) of each wall's surface: a plane's velocity, omega R of a turning cylinder, a
    mesh's |v| + |omega| (farthest corner from its axis)."""
    speeds = []
    for w in sim.walls:
        if w["shape"] == "plane":
            speeds.append(float(np.linalg.norm(w["velocity"])))
        elif w["shape"] == "cylinder":
            speeds.append(abs(w["angular_velocity"]) * w["radius"])
        else:
            speeds.append(mesh_speed(w, sim.mesh_triangles[w["name"]]))
    return speeds


def overlap_ratios(sim, x=None, radius=None) -> np.ndarray:
    """(walls, particles) overlap / radius, > 0 where a particle overlaps a wall (sim's particles, or spheres at
    x (m, n x 3) with radius (m, n)).

    Plane: r - |(x - p).n| (two-sided; outside its bounds: no contact); cylinder: r - (R - rho) inside,
    r - (rho - R) outside, rho the distance from its axis (outside its extent: no contact); mesh: r - the
    distance to its nearest triangle (physics.md, walls; engine/mesh.py).
    """
    if x is None:
        x, radius = sim.state.x, sim.state.radius
    gaps = []
    planes, cylinders, mesh_walls = (of_shape(sim.walls, s) for s in SHAPES)
    for w, p in zip(planes, sim.plane_point):
        sep = (x - p) @ np.asarray(w["normal"])
        gap = np.abs(sep) - radius
        if w.get("bounds"):
            foot = x - np.outer(sep, w["normal"])
            inside = np.all((foot >= w["bounds"]["lo"]) & (foot <= w["bounds"]["hi"]), axis=1)
            gap = np.where(inside, gap, np.inf)
        gaps.append(gap)
    for w in cylinders:
        rel = x - np.asarray(w["point"])
        axis = np.asarray(w["axis"])
        along = rel @ axis
        rho = np.linalg.norm(rel - np.outer(along, axis), axis=1)
        gap = ((w["radius"] - rho) if w["side"] == "inside" else (rho - w["radius"])) - radius
        if w["extent"]:
            gap = np.where((along >= w["extent"][0]) & (along <= w["extent"][1]), gap, np.inf)
        gaps.append(gap)
    if mesh_walls:
        ws = wall_set(sim)
        for k, w in enumerate(mesh_walls):
            tv = np.ascontiguousarray(ws.tri_v[ws.tri_mesh == k])
            gaps.append(-meshes.overlap_ratios(x, radius, len(x), tv) * radius)
    return -np.array(gaps).reshape(-1, len(x)) / radius
