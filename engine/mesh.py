"""Triangle mesh walls: loading STL files, their topology, sphere-triangle contact and the sparse contact list.

A mesh wall is a set of triangles (m, from an ASCII or binary STL file read by VTK's vtkSTLReader) placed with
scale, rotation and translation on load, and optionally moving: translation at a velocity, rotation about an
axis through a point at an angular velocity (a rotating drum, a mixer blade).

**Contact** (as LIGGGHTS' mesh/surface, engine/README.md gives the sources): a sphere of radius r at x touches
triangle t when the point c of t closest to x is nearer than r. c lies in the face, on an edge or on a corner
of t (Ericson, Real-Time Collision Detection, 2005, 5.1.5: the Voronoi regions of the triangle). A face
contact has the normal of the face; an edge or corner contact the direction x - c. So that a sphere touching a
mesh is pushed once per point of the surface it touches, whatever the triangulation:

- a face contact always counts;
- an edge or corner contact counts only where it is the closest point of every triangle sharing that edge or
  corner (otherwise a neighbouring triangle is closer to the sphere, and that one pushes: this removes the
  edges between coplanar triangles and the false contacts at convex edges next to a face contact), and only
  once: by the lowest-numbered of those triangles.

**Sparse history**: each particle keeps a short list of the triangles within r + skin of its centre (CSR rows,
built at every neighbor rebuild on a cell grid of the triangles), with the contact history of each entry. The
memory is proportional to the particles near the mesh, never particles x triangles. History follows a particle
by its id through re-ordering and through particles inserted or removed between steps.

**Motion**: the vertices are recomputed every step from their reference positions: v = R(angle) (v0 - p0) + p0
+ shift, with angle = sum of omega dt and shift = sum of velocity dt (Rodrigues' rotation formula). The lists are
rebuilt when the mesh may have moved by more than skin/2 since the last rebuild (the particles' own criterion,
so that together they never close more than the skin).
"""
from __future__ import annotations

import math
import re
import struct
from collections import namedtuple
from pathlib import Path

import numpy as np
from numba import prange

from .jit import njit
from .neighbor import PARALLEL

#: start (n+1): rows of particle i are start[i]..start[i+1]; tri (int32): the triangle of each entry; hist
#: (entries, width): contact history; touch (entries, uint8): the entry is a contact at this step; owner (n):
#: the particle id each row belonged to when it was built
MeshList = namedtuple("MeshList", ["start", "tri", "hist", "touch", "owner"])

#: contact regions of closest_point
FACE, EDGE0, EDGE1, EDGE2, CORNER0, CORNER1, CORNER2 = range(7)


def empty_mesh_list(n: int = 0, history: int = 0) -> MeshList:
    return MeshList(np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int32), np.zeros((0, history)),
                    np.zeros(0, dtype=np.uint8), np.full(n, -1, dtype=np.int64))


# ---------------------------------------------------------------- loading and topology

class MeshError(ValueError):
    """A mesh file that cannot be used (the caller names the command and field)."""


def read_stl(path: str) -> np.ndarray:
    """Triangles (m, 3, 3) of an ASCII or binary STL file, in file order, in the file's units.

    The coordinates are single precision, as binary STL stores them (VTK reads ASCII files into single
    precision too): 0.04 in a file is 0.03999999910593033. Meshes meant to coincide with other walls to
    round-off use coordinates that single precision holds exactly (0.0390625 = 5/128, 0.25, ...)."""
    import vtk  # heavy: only scenes with meshes load it

    file = Path(path)
    if not file.is_file():
        raise MeshError(f"file '{path}' does not exist")
    expected = _stl_layout(file, path)
    reader = vtk.vtkSTLReader()
    reader.SetFileName(str(file))
    reader.MergingOff()  # keep every triangle's own three points; welding is done here, exactly
    # VTK reports a broken file on stderr itself; the engine says it in one line instead
    vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_OFF)
    errors = vtk.vtkStringOutputWindow()
    previous = vtk.vtkOutputWindow.GetInstance()
    vtk.vtkOutputWindow.SetInstance(errors)
    try:
        reader.Update()
    finally:
        vtk.vtkOutputWindow.SetInstance(previous)
    data = reader.GetOutput()
    if reader.GetErrorCode() or data is None or data.GetNumberOfPolys() == 0:
        raise MeshError(f"file '{path}' is not an STL file with triangles")
    from vtk.util.numpy_support import vtk_to_numpy  # vtk loads in seconds: only scenes with STL walls

    points = vtk_to_numpy(data.GetPoints().GetData()).astype(np.float64)
    polys = data.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray())
    if np.any(np.diff(offsets) != 3):
        raise MeshError(f"file '{path}' has faces that are not triangles")
    triangles = points[vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3)]
    if expected is not None and len(triangles) != expected:
        raise MeshError(f"file '{path}' declares {expected} triangles but {len(triangles)} were read "
                        "(a truncated or damaged file: a wall would silently lose faces)")
    if not np.all(np.isfinite(triangles)):
        raise MeshError(f"file '{path}' has vertices that are not finite numbers")
    return np.ascontiguousarray(triangles)


def _stl_layout(file: Path, path: str) -> int | None:
    """The number of triangles an STL file declares, checked against its size, before VTK reads it (VTK reads
    the triangles that are there and says nothing of the rest).

    Binary STL: an 80-byte header, a little-endian uint32 count, then 50 bytes per triangle; a file shorter
    than 84 + 50 count bytes is cut (inside a triangle or after one). ASCII STL (starts with ``solid``, text
    only): every ``facet`` needs its ``endfacet``, and the file its ``endsolid``."""
    try:
        with open(file, "rb") as handle:
            data = handle.read()
    except OSError as exc:
        raise MeshError(f"file '{path}' cannot be read: {exc.strerror}") from None
    if len(data) >= 84:
        (count,) = struct.unpack_from("<I", data, 80)
        if len(data) == 84 + 50 * count:
            return count
    text = data.lstrip()
    if text[:5].lower() == b"solid":
        try:
            text.decode("ascii")
        except UnicodeDecodeError:
            text = None
        if text is not None:
            facets, ends = len(re.findall(rb"\bfacet\b", text)), len(re.findall(rb"\bendfacet\b", text))
            if facets == 0:
                raise MeshError(f"file '{path}' is not an STL file with triangles (no 'facet')")
            if facets != ends or not re.search(rb"\bendsolid\b", text):
                raise MeshError(f"file '{path}' is an ASCII STL file cut short ({facets} 'facet', {ends} "
                                "'endfacet', " + ("an" if re.search(rb"\bendsolid\b", text) else "no")
                                + " 'endsolid')")
            return ends
    if len(data) < 84:
        raise MeshError(f"file '{path}' is not an STL file with triangles ({len(data)} bytes)")
    (count,) = struct.unpack_from("<I", data, 80)
    if len(data) < 84 + 50 * count:
        whole = (len(data) - 84) // 50
        raise MeshError(f"file '{path}' is a binary STL file whose header declares {count} triangles, but its "
                        f"{len(data)} bytes hold {whole}" + (" and part of another" if (len(data) - 84) % 50 else "")
                        + " (truncated)")
    return None  # longer than declared: trailing bytes some exporters add; VTK reads the declared triangles


def rotation_matrix(axis, angle: float) -> np.ndarray:
    """Rotation by angle (rad) about the unit vector of axis, right-handed (Rodrigues)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def place(triangles: np.ndarray, scale: float = 1.0, rotate=None, translate=None) -> np.ndarray:
    """Triangles scaled (about the origin), then rotated (rotate = (axis, angle in degrees) about the origin),
    then translated; the identity leaves every coordinate bitwise as it was."""
    out = triangles * scale if scale != 1.0 else triangles.copy()
    if rotate is not None and rotate[1] % 360.0 != 0.0:
        out = out @ rotation_matrix(rotate[0], math.radians(rotate[1])).T
    if translate is not None and any(translate):
        out = out + np.asarray(translate, dtype=np.float64)
    return np.ascontiguousarray(out)


def degenerate(triangles: np.ndarray) -> np.ndarray:
    """Indices of triangles of zero area (they have no normal)."""
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return np.nonzero(np.einsum("ij,ij->i", cross, cross) == 0.0)[0]


def topology(triangles: np.ndarray, first: int = 0):
    """(vertex ids (m, 3), fan_start, fan_tri): corners with bitwise equal coordinates are one vertex; the
    triangles around vertex v are fan_tri[fan_start[v]:fan_start[v+1]] (numbered from `first`, increasing)."""
    m = len(triangles)
    _, vid = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    vid = vid.reshape(m, 3).astype(np.int64)
    nv = int(vid.max()) + 1 if m else 0
    owner = np.repeat(np.arange(m, dtype=np.int64), 3) + first
    order = np.lexsort((owner, vid.ravel()))
    fan_tri = owner[order]
    fan_start = np.zeros(nv + 1, dtype=np.int64)
    np.add.at(fan_start, vid.ravel() + 1, 1)
    fan_start = np.cumsum(fan_start)
    return vid, fan_start, fan_tri


def flat_parts(vid: np.ndarray, unit_normals: np.ndarray) -> np.ndarray:
    """(m, 6) uint8: for each triangle's edges (0-1, 1-2, 2-0) and corners (0, 1, 2), whether it lies inside a
    flat part of the mesh - an edge shared by exactly two triangles of the same plane, a corner all of whose
    edges are such edges. There an edge or corner contact can only count when the sphere's centre is right
    over it (otherwise a neighbouring face is nearer), a test the kernel makes without visiting the
    neighbours."""
    m = len(vid)
    users: dict = {}
    for t in range(m):
        for e in range(3):
            a, b = int(vid[t, e]), int(vid[t, (e + 1) % 3])
            users.setdefault((min(a, b), max(a, b)), []).append((t, e))
    flat = np.zeros((m, 6), dtype=np.uint8)
    vertex_flat: dict = {}
    for key, sharing in users.items():
        coplanar = len(sharing) == 2 and abs(float(np.dot(unit_normals[sharing[0][0]],
                                                          unit_normals[sharing[1][0]]))) >= 1.0 - 1e-12
        for t, e in sharing:
            flat[t, e] = coplanar
        for v in key:
            vertex_flat[v] = vertex_flat.get(v, True) and coplanar
    for t in range(m):
        for c in range(3):
            flat[t, 3 + c] = vertex_flat[int(vid[t, c])]
    return flat


def normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals (m, 3) by the right-hand rule on the corner order."""
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return cross / np.sqrt(np.einsum("ij,ij->i", cross, cross))[:, None]


# ---------------------------------------------------------------- compiled geometry

@njit(cache=True, error_model="numpy", inline="always")
def _corner_dots(px, py, pz, tv, t, k, abx, aby, abz, acx, acy, acz):
    """ab . (p - corner k) and ac . (p - corner k) of triangle t: the barycentric tests of closest_point."""
    qx = px - tv[t, k, 0]
    qy = py - tv[t, k, 1]
    qz = pz - tv[t, k, 2]
    return abx * qx + aby * qy + abz * qz, acx * qx + acy * qy + acz * qz


@njit(cache=True, error_model="numpy", inline="always")
def _corner_or_edge(tv, t, k, own, cross, a_own, a_cross, ax, ay, az, ex, ey, ez, corner_region, edge_region):
    """Ericson's tests of corner k (1 or 2) of triangle t and of the edge from corner 0 to it (direction e):
    ``own`` and ``cross`` are p - corner k dotted with e and with the other edge, ``a_own`` and ``a_cross`` the
    same of p - corner 0. (hit, closest point, region, the barycentric numerator v of the edge)."""
    v = a_own * cross - own * a_cross
    if own >= 0.0 and cross <= own:
        return True, tv[t, k, 0], tv[t, k, 1], tv[t, k, 2], corner_region, v
    if v <= 0.0 and a_own >= 0.0 and own <= 0.0:
        s = a_own / (a_own - own)
        return True, ax + s * ex, ay + s * ey, az + s * ez, edge_region, v
    return False, ax, ay, az, 0, v


@njit(cache=True, error_model="numpy", inline="always")
def closest_point(px, py, pz, tv, t):
    """The point of triangle t (corners tv[t, 0..2]) closest to p, and its region (FACE, EDGE0 = corners 0-1,
    EDGE1 = 1-2, EDGE2 = 2-0, CORNER0..2). Ericson (2005) 5.1.5, by the signs of the barycentric parameters."""
    ax = tv[t, 0, 0]
    ay = tv[t, 0, 1]
    az = tv[t, 0, 2]
    abx = tv[t, 1, 0] - ax
    aby = tv[t, 1, 1] - ay
    abz = tv[t, 1, 2] - az
    acx = tv[t, 2, 0] - ax
    acy = tv[t, 2, 1] - ay
    acz = tv[t, 2, 2] - az
    d1, d2 = _corner_dots(px, py, pz, tv, t, 0, abx, aby, abz, acx, acy, acz)
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, 4
    d3, d4 = _corner_dots(px, py, pz, tv, t, 1, abx, aby, abz, acx, acy, acz)
    hit, qx, qy, qz, region, vc = _corner_or_edge(tv, t, 1, d3, d4, d1, d2, ax, ay, az, abx, aby, abz, 5, 1)
    if hit:
        return qx, qy, qz, region
    d5, d6 = _corner_dots(px, py, pz, tv, t, 2, abx, aby, abz, acx, acy, acz)
    hit, qx, qy, qz, region, vb = _corner_or_edge(tv, t, 2, d6, d5, d2, d1, ax, ay, az, acx, acy, acz, 6, 3)
    if hit:
        return qx, qy, qz, region
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        bx = tv[t, 1, 0]
        by = tv[t, 1, 1]
        bz = tv[t, 1, 2]
        return bx + s * (tv[t, 2, 0] - bx), by + s * (tv[t, 2, 1] - by), bz + s * (tv[t, 2, 2] - bz), 2
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w, 0


@njit(cache=True, error_model="numpy", inline="always")
def _shares(vid, t, a, b):
    """Triangle t has vertex a, and vertex b too (b < 0: any)."""
    has_a = vid[t, 0] == a or vid[t, 1] == a or vid[t, 2] == a
    if b < 0:
        return has_a
    return has_a and (vid[t, 0] == b or vid[t, 1] == b or vid[t, 2] == b)


@njit(cache=True, error_model="numpy")
def edge_or_corner_counts(px, py, pz, cx, cy, cz, region, t, tv, vid, fan_start, fan_tri, tol_sq):
    """Whether the edge or corner contact of triangle t at c counts (module docstring): c is the closest point
    of every triangle sharing that edge or corner, none of them has it in its face (nor, for a corner, on an
    edge), and t is the lowest-numbered of them."""
    if region <= 3:
        a = vid[t, region - 1]
        b = vid[t, region % 3]
    else:
        a = vid[t, region - 4]
        b = -1
    for k in range(fan_start[a], fan_start[a + 1]):
        u = fan_tri[k]
        if u == t or not _shares(vid, u, a, b):
            continue
        qx, qy, qz, r = closest_point(px, py, pz, tv, u)
        if r == 0 or (b < 0 and r <= 3):
            return False
        dx = qx - cx
        dy = qy - cy
        dz = qz - cz
        if dx * dx + dy * dy + dz * dz > tol_sq:
            return False
        if u < t:
            return False
    return True


@njit(cache=True, error_model="numpy")
def take_coplanar_history(hist, tri, touch, first, last, k, tv, tn, tol):
    """A new contact of entry k (triangle t) takes over the history of a triangle in the same plane that the
    particle was touching (its entry still holds history and is not a contact now): a sphere rolling or
    sliding across the edge between two triangles of a flat face keeps its shear history, as on a plane."""
    t = tri[k]
    for q in range(first, last):
        if q == k or (q < k and touch[q] == 1):
            continue
        held = False
        for h in range(hist.shape[1]):
            if hist[q, h] != 0.0:
                held = True
        if not held:
            continue
        u = tri[q]
        parallel = tn[t, 0] * tn[u, 0] + tn[t, 1] * tn[u, 1] + tn[t, 2] * tn[u, 2]
        if abs(parallel) < 1.0 - 1e-12:
            continue
        offset = ((tv[u, 0, 0] - tv[t, 0, 0]) * tn[t, 0] + (tv[u, 0, 1] - tv[t, 0, 1]) * tn[t, 1]
                  + (tv[u, 0, 2] - tv[t, 0, 2]) * tn[t, 2])
        if abs(offset) > tol:
            continue
        for h in range(hist.shape[1]):
            hist[k, h] = hist[q, h]
            hist[q, h] = 0.0
        return


@njit(cache=True, error_model="numpy")
def triangle_distance(px, py, pz, tv, t):
    qx, qy, qz, _ = closest_point(px, py, pz, tv, t)
    return math.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)


# ---------------------------------------------------------------- motion

@njit(cache=True, error_model="numpy", inline="always")
def _placed_corner(tri_v0, t, k, px, py, pz, c, s, kx, ky, kz, sx, sy, sz, rotating):
    """Corner k of triangle t: R (v0 - p0) + p0 + shift, R the rotation by the angle of cosine c and sine s
    about the unit axis k (Rodrigues), or the identity."""
    ux = tri_v0[t, k, 0] - px
    uy = tri_v0[t, k, 1] - py
    uz = tri_v0[t, k, 2] - pz
    if rotating:
        dot = kx * ux + ky * uy + kz * uz
        rx = ux * c + (ky * uz - kz * uy) * s + kx * dot * (1.0 - c)
        ry = uy * c + (kz * ux - kx * uz) * s + ky * dot * (1.0 - c)
        rz = uz * c + (kx * uy - ky * ux) * s + kz * dot * (1.0 - c)
        ux = rx
        uy = ry
        uz = rz
    return ux + px + sx, uy + py + sy, uz + pz + sz


@njit(cache=True, error_model="numpy")
def place_vertices(tri_v0, tri_mesh, point0, axis, angle, shift, tri_v, tri_n, rotating):
    """Current corners and normals of every triangle: v = R(angle) (v0 - p0) + p0 + shift (Rodrigues).

    The triangles of one mesh are consecutive (engine/walls/mesh_wall.py mesh_arrays): the cosine and sine of
    its angle are taken once per run of triangles of one mesh, not per triangle (every step of a rotating
    drum placed all its triangles with a sine and a cosine each), and the normal comes from the corners just
    computed, not from reading them back."""
    nt = tri_v0.shape[0]
    first = 0
    while first < nt:
        m = tri_mesh[first]
        last = first + 1
        while last < nt and tri_mesh[last] == m:
            last += 1
        c = 1.0
        s = 0.0
        kx = ky = kz = 0.0
        if rotating:
            c = math.cos(angle[m])
            s = math.sin(angle[m])
            kx = axis[m, 0]
            ky = axis[m, 1]
            kz = axis[m, 2]
        px = point0[m, 0]
        py = point0[m, 1]
        pz = point0[m, 2]
        sx = shift[m, 0]
        sy = shift[m, 1]
        sz = shift[m, 2]
        for t in range(first, last):
            ax, ay, az = _placed_corner(tri_v0, t, 0, px, py, pz, c, s, kx, ky, kz, sx, sy, sz, rotating)
            bx, by, bz = _placed_corner(tri_v0, t, 1, px, py, pz, c, s, kx, ky, kz, sx, sy, sz, rotating)
            cx, cy, cz = _placed_corner(tri_v0, t, 2, px, py, pz, c, s, kx, ky, kz, sx, sy, sz, rotating)
            tri_v[t, 0, 0] = ax
            tri_v[t, 0, 1] = ay
            tri_v[t, 0, 2] = az
            tri_v[t, 1, 0] = bx
            tri_v[t, 1, 1] = by
            tri_v[t, 1, 2] = bz
            tri_v[t, 2, 0] = cx
            tri_v[t, 2, 1] = cy
            tri_v[t, 2, 2] = cz
            e1x = bx - ax
            e1y = by - ay
            e1z = bz - az
            e2x = cx - ax
            e2y = cy - ay
            e2z = cz - az
            nx = e1y * e2z - e1z * e2y
            ny = e1z * e2x - e1x * e2z
            nz = e1x * e2y - e1y * e2x
            norm = math.sqrt(nx * nx + ny * ny + nz * nz)
            tri_n[t, 0] = nx / norm
            tri_n[t, 1] = ny / norm
            tri_n[t, 2] = nz / norm
        first = last


@njit(cache=True, error_model="numpy")
def shift_vertices(tri_v0, tri_mesh, shift, tri_v):
    """Current corners of meshes that only translate: v = v0 + shift (the normals stay)."""
    for t in range(tri_v0.shape[0]):
        m = tri_mesh[t]
        for k in range(3):
            for a in range(3):
                tri_v[t, k, a] = tri_v0[t, k, a] + shift[m, a]


# ---------------------------------------------------------------- the sparse contact list

@njit(cache=True, error_model="numpy")
def _triangle_grid(tv, reach, n):
    """Cell grid over the triangles' bounding box inflated by reach: (origin, cell, nc, cell_start, cell_tri),
    every triangle listed in every cell its bounding box inflated by reach touches."""
    m = tv.shape[0]
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for t in range(m):
        for k in range(3):
            for a in range(3):
                lo[a] = min(lo[a], tv[t, k, a])
                hi[a] = max(hi[a], tv[t, k, a])
    origin = lo - reach
    extent = hi - lo + 2.0 * reach
    cell = reach
    nc = np.ones(3, dtype=np.int64)
    while True:
        for a in range(3):
            nc[a] = int(extent[a] / cell) + 1
        if nc[0] * nc[1] * nc[2] <= 8 * (m + n) + 64:
            break
        cell *= 1.25
    ncells = nc[0] * nc[1] * nc[2]
    ranges = np.empty((m, 3, 2), dtype=np.int64)
    cell_start = np.zeros(ncells + 1, dtype=np.int64)
    for t in range(m):
        for a in range(3):
            tlo = min(tv[t, 0, a], tv[t, 1, a], tv[t, 2, a]) - reach
            thi = max(tv[t, 0, a], tv[t, 1, a], tv[t, 2, a]) + reach
            ranges[t, a, 0] = max(int((tlo - origin[a]) / cell), 0)
            ranges[t, a, 1] = min(int((thi - origin[a]) / cell), nc[a] - 1)
        for cx in range(ranges[t, 0, 0], ranges[t, 0, 1] + 1):
            for cy in range(ranges[t, 1, 0], ranges[t, 1, 1] + 1):
                for cz in range(ranges[t, 2, 0], ranges[t, 2, 1] + 1):
                    cell_start[(cx * nc[1] + cy) * nc[2] + cz + 1] += 1
    for c in range(ncells):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    cell_tri = np.empty(cell_start[ncells], dtype=np.int32)
    for t in range(m):  # in increasing t: each cell lists its triangles in increasing order
        for cx in range(ranges[t, 0, 0], ranges[t, 0, 1] + 1):
            for cy in range(ranges[t, 1, 0], ranges[t, 1, 1] + 1):
                for cz in range(ranges[t, 2, 0], ranges[t, 2, 1] + 1):
                    key = (cx * nc[1] + cy) * nc[2] + cz
                    cell_tri[fill[key]] = t
                    fill[key] += 1
    return origin, cell, nc, cell_start, cell_tri


@njit(cache=True, error_model="numpy", inline="always")
def _cell_of(px, py, pz, origin, cell, nc):
    """Cell key of a point, -1 outside the grid."""
    key = 0
    for a in range(3):
        p = px if a == 0 else (py if a == 1 else pz)
        c = (p - origin[a]) / cell
        if not (c >= 0.0 and c < nc[a]):
            return -1
        key = key * nc[a] + int(c)
    return key


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _scan(x, radius, n, tv, skin, origin, cell, nc, cell_start, cell_tri, room, hits, count):
    """Per particle: the triangles of its cell within radius + skin of its centre, in increasing order, written
    into hits from room[i] (room for every triangle its cell lists), their number into count[i]. One distance
    test per (particle, listed triangle): a pass that counted and a second that wrote tested each pair twice."""
    for i in prange(n):
        key = _cell_of(x[i, 0], x[i, 1], x[i, 2], origin, cell, nc)
        found = 0
        if key >= 0:
            reach = radius[i] + skin
            for k in range(cell_start[key], cell_start[key + 1]):
                t = cell_tri[k]
                if triangle_distance(x[i, 0], x[i, 1], x[i, 2], tv, t) < reach:
                    hits[room[i] + found] = t
                    found += 1
        count[i] = found


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _carry(pid, n, start, tri, hist, old_start, old_tri, old_hist, row_of):
    """Each new entry (particle, triangle) takes the history of the same entry of the old list, found by the
    particle's id."""
    width = hist.shape[1]
    for i in prange(n):
        p = pid[i]
        r = row_of[p] if p < row_of.shape[0] else -1
        if r < 0:
            continue
        for k in range(start[i], start[i + 1]):
            for q in range(old_start[r], old_start[r + 1]):
                if old_tri[q] == tri[k]:
                    for h in range(width):
                        hist[k, h] = old_hist[q, h]
                    break


@njit(cache=True, error_model="numpy")
def mesh_rebuild(s, n, old, tv, skin):
    """The contact list of the first n particles of state s against the triangles tv (their current corners),
    keeping the history of every (particle id, triangle) entry that stays."""
    x = s.x
    radius = s.radius
    pid = s.pid
    start = np.zeros(n + 1, dtype=np.int64)
    width = old.hist.shape[1]
    if n == 0 or tv.shape[0] == 0:
        return MeshList(start, np.zeros(0, dtype=np.int32), np.zeros((0, width)), np.zeros(0, dtype=np.uint8),
                        pid[:n].copy())
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    origin, cell, nc, cell_start, cell_tri = _triangle_grid(tv, rmax + skin, n)
    room = np.empty(n + 1, dtype=np.int64)  # each particle's room in hits: as many as its cell lists
    room[0] = 0
    for i in range(n):
        key = _cell_of(x[i, 0], x[i, 1], x[i, 2], origin, cell, nc)
        room[i + 1] = room[i] + (cell_start[key + 1] - cell_start[key] if key >= 0 else 0)
    hits = np.empty(room[n], dtype=np.int32)
    count = np.empty(n, dtype=np.int64)
    _scan(x, radius, n, tv, skin, origin, cell, nc, cell_start, cell_tri, room, hits, count)
    for i in range(n):
        start[i + 1] = start[i] + count[i]
    tri = np.empty(start[n], dtype=np.int32)
    for i in range(n):
        for k in range(count[i]):
            tri[start[i] + k] = hits[room[i] + k]
    hist = np.zeros((start[n], width))
    if width > 0 and old.tri.shape[0] > 0:
        top = 0
        for r in range(old.owner.shape[0]):
            top = max(top, old.owner[r])
        row_of = np.full(top + 1, -1, dtype=np.int64)
        for r in range(old.owner.shape[0]):
            if old.owner[r] >= 0:
                row_of[old.owner[r]] = r
        _carry(pid, n, start, tri, hist, old.start, old.tri, old.hist, row_of)
    return MeshList(start, tri, hist, np.zeros(start[n], dtype=np.uint8), pid[:n].copy())


@njit(cache=True, error_model="numpy")
def overlap_ratios(x, radius, n, tv):
    """Largest overlap / radius of each particle with any triangle (brute force; start of a run only)."""
    out = np.zeros(n)
    for i in range(n):
        worst = -np.inf
        for t in range(tv.shape[0]):
            worst = max(worst, (radius[i] - triangle_distance(x[i, 0], x[i, 1], x[i, 2], tv, t)) / radius[i])
        out[i] = worst
    return out
