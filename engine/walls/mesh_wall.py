"""Mesh walls: triangles from an STL file (`engine.mesh`), moving at a velocity and/or rotating about an axis
through a point; their contacts and history live in a sparse per-particle list (`engine.mesh.MeshList`)."""
from __future__ import annotations

import numpy as np

from .. import mesh as meshes
from ..script import Fields
from ..templates import render
from .shape import KernelPart, WallShape, axis_or_vector, numbers, rows

#: the triangles in particle i's rows of the mesh list (engine/mesh.py): closest point, region, and whether an
#: edge or corner contact counts; a face contact has the face normal (as a plane), an edge or corner contact
#: the direction from the closest point c to the centre
MESH_CONTACTS = """\
for k in range(mesh_start[i], mesh_start[i + 1]):
    t = mesh_tri[k]
    nx = tri_n[t, 0]
    ny = tri_n[t, 1]
    nz = tri_n[t, 2]
    tax = tri_v[t, 0, 0]
    tay = tri_v[t, 0, 1]
    taz = tri_v[t, 0, 2]
    sep = (xi0 - tax) * nx + (xi1 - tay) * ny + (xi2 - taz) * nz
    # most listed triangles do not touch (the list reaches r + skin): one whose plane is r or more away cannot,
    # since the closest point c lies in the plane (|x - c| >= |sep|), and needs no closest point. The margin
    # lies far above the round-off of sep and |x - c| (a few ulps of the coordinates), so that this test never
    # decides otherwise than the distance below (MESH_NEAR)
    if abs(sep) >= ri + ${near} * (ri + abs(xi0) + abs(xi1) + abs(xi2) + abs(tax) + abs(tay) + abs(taz)):
        mesh_touch[k] = 0
        continue
    cx, cy, cz, region = closest_point(xi0, xi1, xi2, tri_v, t)
    # every name below is set on every path: Numba's parallel loops treat a name that some path leaves unset
    # as shared between threads
    gx = xi0 - cx
    gy = xi1 - cy
    gz = xi2 - cz
    if region == 0:
        dist = abs(sep)
    else:
        dist = sqrt(gx * gx + gy * gy + gz * gz)
    if dist >= ri or dist == 0.0:
        mesh_touch[k] = 0
        continue
    # an edge or corner contact with the centre right over it (a sphere rolling along the edge between two
    # triangles of a flat face) takes the face's normal and distance, as on a plane, not the rounded c
    over = region == 0 or dist - abs(sep) <= 1e-12 * dist
    if region != 0:
        if not over and tri_flat[t, region - 1] != 0:
            # inside a flat part: a neighbouring face is nearer (engine/mesh.py flat_parts)
            mesh_touch[k] = 0
            continue
        if not edge_or_corner_counts(xi0, xi1, xi2, cx, cy, cz, region, t, tri_v, tri_vid, fan_start, fan_tri,
                                     1e-20 * ri * ri):
            mesh_touch[k] = 0
            continue
    if over:
        dist = abs(sep)
        sign = 1.0 if sep >= 0.0 else -1.0
        enx = sign * nx + 0.0
        eny = sign * ny + 0.0
        enz = sign * nz + 0.0
    else:
        enx = gx / dist
        eny = gy / dist
        enz = gz / dist
    mesh_touch[k] = 1
    ${take_history}
    d = ri - dist
    mk = tri_mesh[t]
    w = mesh_wall0[0] + mk
    tj = mesh_type[mk]
    ${surface_velocity}
    vn = vrx * enx + vry * eny + vrz * enz
    ${contact}
${reset_history}
"""
#: the relative margin of the plane test of MESH_CONTACTS: 1e-12 of the coordinates' magnitude, about 5,000 times
#: the round-off of a distance computed from them (2.2e-16 per operation, a few operations)
MESH_NEAR = "1e-12"
#: a new contact with no history looks for the history of a triangle of the same plane the particle leaves
#: (engine/mesh.py take_coplanar_history); entries that are no contact lose their history after the loop, so
#: that the order of the entries does not matter
MESH_TAKE_HISTORY = """\
fresh = True
for h in range(${width}):
    if mesh_hist[k, h] != 0.0:
        fresh = False
if fresh:
    take_coplanar_history(mesh_hist, mesh_tri, mesh_touch, mesh_start[i], mesh_start[i + 1], k, tri_v, tri_n,
                          1e-9 * ri)
"""
MESH_RESET = """\
for k in range(mesh_start[i], mesh_start[i + 1]):
    if mesh_touch[k] == 0:
        for h in range(${width}):
            mesh_hist[k, h] = 0.0
"""
#: a mesh's surface velocity at the contact point: its translation, plus omega a x (c - p) when it rotates
MESH_VELOCITY = """\
vrx = vix - mesh_vel[mk, 0]
vry = viy - mesh_vel[mk, 1]
vrz = viz - mesh_vel[mk, 2]
"""
MESH_SPIN = """\
qx = cx - (mesh_point0[mk, 0] + mesh_shift[mk, 0])
qy = cy - (mesh_point0[mk, 1] + mesh_shift[mk, 1])
qz = cz - (mesh_point0[mk, 2] + mesh_shift[mk, 2])
om = mesh_omega[mk]
vrx -= om * (mesh_axis[mk, 1] * qz - mesh_axis[mk, 2] * qy)
vry -= om * (mesh_axis[mk, 2] * qx - mesh_axis[mk, 0] * qz)
vrz -= om * (mesh_axis[mk, 0] * qy - mesh_axis[mk, 1] * qx)
"""
#: meshes: angle and shift advance, the corners are placed anew (engine/mesh.py); how far a corner may have
#: moved since the last rebuild grows by the fastest mesh's corner speed
MOVE_MESHES = """\
fastest = 0.0
for m in range(walls.mesh_angle.shape[0]):
    ${turn}
    for a in range(3):
        walls.mesh_shift[m, a] += walls.mesh_vel[m, a] * dt
    fastest = max(fastest, walls.mesh_speed[m])
walls.travel[0] += fastest * dt
${place}
"""
PLACE_TURNING = """\
place_vertices(walls.tri_v0, walls.tri_mesh, walls.mesh_point0, walls.mesh_axis, walls.mesh_angle, walls.mesh_shift,
               walls.tri_v, walls.tri_n, True)
"""
PLACE_SHIFTED = "shift_vertices(walls.tri_v0, walls.tri_mesh, walls.mesh_shift, walls.tri_v)\n"
#: a mesh that may have moved by more than skin/2 since the last rebuild: rebuild (the particles' own criterion)
MESH_TRAVEL = "if walls.travel[0] > 0.5 * skin:\n    need += 1\n"
MESH_REBUILD = "mnbr = mesh_rebuild(s, n, mnbr, walls.tri_v, skin)\nwalls.travel[0] = 0.0\n"



def rotation_of(w) -> tuple:
    """(point m, unit axis, angular velocity rad/s) of a mesh's rotation; the origin and no turn without one."""
    rot = w.get("rotation")
    if not rot:
        return [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.0
    return rot["point"], rot["axis"], rot["angular_velocity"]


def mesh_speed(w: dict, triangles: np.ndarray) -> float:
    """The fastest corner of a mesh (m/s): |v| + |omega| x (largest distance of a corner from its axis)."""
    point, axis, omega = rotation_of(w)
    corners = triangles.reshape(-1, 3) - np.asarray(point, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    radial = corners - np.outer(corners @ axis, axis)
    reach = float(np.sqrt(np.max(np.einsum("ij,ij->i", radial, radial)))) if len(corners) else 0.0
    return float(np.linalg.norm(w["velocity"])) + abs(omega) * reach


def mesh_arrays(mesh_walls: list[dict], triangles: dict) -> dict:
    """The meshes' triangle arrays (reference corners, mesh index, topology over all meshes)."""
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


def load_mesh(sim, fields: Fields, wall: dict) -> np.ndarray:
    """The placed triangles of a mesh wall's STL file; its placement and motion go into the wall dict."""
    wall["file"] = fields.string("file", required=True)
    wall["scale"] = fields.number("scale", 1.0, positive=True)
    rotate = fields.mapping("rotate")
    if rotate is not None:
        sub = Fields(rotate, fields.where + ", rotate")
        rotate = dict(axis=axis_or_vector(sub, "axis", required=True), angle=sub.number("angle", required=True))
        sub.finish()
    wall["rotate"] = rotate
    wall["translate"] = fields.vector("translate", default=[0.0, 0.0, 0.0])
    wall["velocity"] = fields.vector("velocity", default=[0.0, 0.0, 0.0])
    rotation = fields.mapping("rotation")
    if rotation is not None:
        sub = Fields(rotation, fields.where + ", rotation")
        rotation = dict(point=sub.vector("point", default=[0.0, 0.0, 0.0]),
                        axis=axis_or_vector(sub, "axis", required=True),
                        angular_velocity=sub.number("angular_velocity", required=True))
        sub.finish()
    wall["rotation"] = rotation
    try:
        triangles = meshes.read_stl(wall["file"])
    except meshes.MeshError as exc:
        raise fields.error("file", str(exc)) from None
    triangles = meshes.place(triangles, wall["scale"], (rotate["axis"], rotate["angle"]) if rotate else None,
                             wall["translate"])
    flat = meshes.degenerate(triangles)
    if len(flat):
        raise fields.error("file", f"'{wall['file']}' has {len(flat)} triangle(s) of zero area (the first is "
                           f"triangle {int(flat[0]) + 1}); they have no normal")
    sim.log.info(f"mesh wall '{wall['name']}': {len(triangles)} triangles from {wall['file']}, bounding box "
                 f"{triangles.reshape(-1, 3).min(axis=0).tolist()} .. {triangles.reshape(-1, 3).max(axis=0).tolist()} m")
    return triangles


class Mesh(WallShape):
    name = "mesh"
    #: reference corners (m, 3, 3), current corners and unit normals, mesh of each triangle, vertex ids, flat
    #: edges and corners (engine.mesh.flat_parts) and vertex -> triangles (fan) of the topology; per mesh: type,
    #: velocity (m/s), rotation point at the start (m), unit rotation axis, angular velocity (rad/s), angle
    #: turned (rad) and shift (m) so far, how far (m) its farthest corner moves per unit time (for the rebuild
    #: criterion), the wall index of its first mesh; travel (1): how far meshes may have moved since the last
    #: rebuild (m)
    fields = ("tri_v0", "tri_v", "tri_n", "tri_mesh", "tri_vid", "tri_flat", "fan_start", "fan_tri",
              "mesh_type", "mesh_vel", "mesh_point0", "mesh_axis", "mesh_omega", "mesh_angle", "mesh_shift",
              "mesh_speed", "mesh_wall0", "travel")
    features = ("meshes", "mesh_motion", "mesh_rotation")
    dense_history = False

    def parse(self, sim, fields, wall):
        return load_mesh(sim, fields, wall)

    def valid(self, w):
        return isinstance(w.get("file"), str) and numbers(w.get("velocity"), 3)

    def arrays(self, sim, walls):
        m = mesh_arrays(walls, sim.mesh_triangles)
        rotations = [rotation_of(w) for w in walls]
        mesh_point0 = rows([r[0] for r in rotations])
        mesh_axis = rows([r[1] for r in rotations])
        mesh_omega = np.array([r[2] for r in rotations], dtype=np.float64)
        tri_v = np.empty_like(m["tri_v0"])
        tri_n = np.empty((len(tri_v), 3))
        if len(tri_v):
            meshes.place_vertices(m["tri_v0"], m["tri_mesh"], mesh_point0, mesh_axis, sim.mesh_angle,
                                  sim.mesh_shift, tri_v, tri_n, bool(np.any(mesh_omega != 0.0)))
        dense = sum(1 for w in sim.walls if w["shape"] != "mesh")
        return dict(m, tri_v=tri_v, tri_n=tri_n, mesh_type=np.array([w["type"] - 1 for w in walls], dtype=np.int64),
                    mesh_vel=rows([w["velocity"] for w in walls]), mesh_point0=mesh_point0, mesh_axis=mesh_axis,
                    mesh_omega=mesh_omega, mesh_angle=sim.mesh_angle, mesh_shift=sim.mesh_shift,
                    mesh_speed=np.array([mesh_speed(w, sim.mesh_triangles[w["name"]]) for w in walls],
                                        dtype=np.float64),
                    mesh_wall0=np.array([dense], dtype=np.int64), travel=sim.mesh_travel)

    def flags(self, walls):
        return dict(meshes=bool(walls), mesh_motion=any(any(w["velocity"]) or w.get("rotation") for w in walls),
                    mesh_rotation=any(w.get("rotation") for w in walls))

    def speed(self, sim, w):
        return mesh_speed(w, sim.mesh_triangles[w["name"]])

    def reference_points(self, sim, walls):
        """The rotation point (the origin without a rotation), moved with the mesh."""
        return [np.asarray(rotation_of(w)[0], float) + sim.mesh_shift[k] for k, w in enumerate(walls)]

    def gaps(self, sim, walls, x, radius):
        """The distance to each mesh's nearest triangle, minus r."""
        if not walls:
            return []
        tri_v = self.arrays(sim, walls)
        gaps = []
        for k in range(len(walls)):
            tv = np.ascontiguousarray(tri_v["tri_v"][tri_v["tri_mesh"] == k])
            gaps.append(-meshes.overlap_ratios(x, radius, len(x), tv) * radius)
        return gaps

    def restore_motion(self, sim, old_walls, walls):
        old = {w["name"]: (a, s) for w, a, s in zip(old_walls, sim.mesh_angle, sim.mesh_shift)}
        motion = [old.get(w["name"], (0.0, np.zeros(3))) for w in walls]
        sim.mesh_angle = np.array([m[0] for m in motion], dtype=np.float64)
        sim.mesh_shift = rows([m[1] for m in motion])

    def kernel(self, c):
        if not c.meshes:
            return KernelPart()

        def contacts(contact, reset):
            width = str(c.history_width)
            return render(MESH_CONTACTS, contact=contact("mesh"), near=MESH_NEAR,
                          take_history=render(MESH_TAKE_HISTORY, width=width) if c.history_width else "",
                          reset_history=render(MESH_RESET, width=width) if c.history_width else "",
                          surface_velocity=MESH_VELOCITY + (MESH_SPIN if c.mesh_rotation else ""))
        move = render(MOVE_MESHES, place=PLACE_TURNING if c.mesh_rotation else PLACE_SHIFTED,
                      turn="walls.mesh_angle[m] += walls.mesh_omega[m] * dt" if c.mesh_rotation else "") \
            if c.mesh_motion else ""
        return KernelPart(contacts=contacts, move=move, travel=MESH_TRAVEL if c.mesh_motion else "",
                          after_rebuild=MESH_REBUILD, setup=MESH_REBUILD,
                          calls=(meshes.closest_point, meshes.edge_or_corner_counts, meshes.mesh_rebuild,
                                 meshes.place_vertices, meshes.shift_vertices, meshes.take_coplanar_history))
