"""Kernel builder: one compiled step loop per combination of named submodels.

A scene names its contact submodels (normal, tangential, cohesion, rolling), its kinds of walls (planes,
bounded planes, cylinders with a turning surface or an extent, meshes that stand, translate or rotate: the
fields of `engine.walls.features`), gravity and periodic axes: a `Combination`. The builder fills the templates below - the
neighbor loop, the wall loop and the step loop, each written once, after HOOMD-blue's
``PotentialPair<evaluator>`` - with exactly those pieces: the calls of the laws the scene names
(`engine.models.LAWS`), their parameter columns and history slots. The source goes into a cache folder, named
by a hash of its text, and is compiled with ``engine.jit.njit(cache=True)``: the machine code is keyed by the
content of each function and of the functions it calls, so a second run (another process, another build of
an engine whose kernels did not change) loads it from disk. What the scene does not name is not in the source: no
branch in the pair loop, no history array (pair history has width 0 without a history submodel), no wall pass
without walls, no mesh code without a mesh, no rotation code without a rotating mesh.

Templates are plain text with named slots: a line holding only ``${name}`` is replaced by the slot's lines,
indented as the slot is; ``${name}`` inside a line by its text (`render`).
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import string
import sys
from collections import namedtuple
from dataclasses import dataclass

from . import clumps
from .jit import cache_dir
from .models import LAWS, PARAMETERS, SUBMODELS, choices
from .state import FIELD_NAMES
from .walls import WALL_FIELDS

#: scalars and small arrays every step reads: dt (s), characteristic velocity (m/s, Hooke), gravity (m/s^2, 3),
#: domain lo, hi (m, 3), periodic (3 booleans), skin (m). The fields of a namedtuple that compiled code
#: receives are part of its cache key (engine/jit.py).
Constants = namedtuple("Constants", ["dt", "characteristic_velocity", "gravity", "lo", "hi", "periodic", "skin"])

NORMAL_MODELS = choices("normal")
TANGENTIAL_MODELS = choices("tangential")
COHESION_MODELS = choices("cohesion")
ROLLING_MODELS = choices("rolling")


@dataclass(frozen=True)
class Combination:
    """Everything that changes the compiled code of a scene (parallel: loops compiled for several threads)."""

    normal: str = "hertz"
    tangential: str = "history"
    cohesion: str = "none"
    rolling: str = "none"
    limit_force: bool = False
    tangential_damping: bool = True
    planes: bool = False
    bounded_planes: bool = False
    cylinders: bool = False
    cylinder_spin: bool = False
    cylinder_extent: bool = False
    meshes: bool = False
    mesh_motion: bool = False
    mesh_rotation: bool = False
    gravity: bool = False
    periodic: tuple = (False, False, False)
    clumps: bool = False
    parallel: bool = False

    def law(self, submodel: str):
        """The law named for a submodel, or None ('none')."""
        return LAWS.get((submodel, getattr(self, submodel)))

    def laws(self) -> list:
        """The named laws in evaluation order (normal -> cohesion -> tangential -> rolling, physics.md)."""
        return [law for law in (self.law(kind) for kind in SUBMODELS) if law is not None]

    def parameter_columns(self) -> dict:
        """Parameter name -> column of the per type-pair table, for the parameters the named laws read."""
        used = {p for law in self.laws() for p in law.parameters}
        return {name: k for k, name in enumerate(p for p in PARAMETERS if p in used)}

    def history_offsets(self) -> dict:
        """Submodel -> first history column, for the laws that keep history (in evaluation order)."""
        offsets, width = {}, 0
        for law in self.laws():
            if law.history:
                offsets[law.submodel] = width
                width += law.history
        return offsets

    def reaction_columns(self) -> dict:
        """What a pair leaves for its partner j: the force (3 columns) and, per submodel that turns j, its torque
        contribution (3 columns) -> first column in the neighbor list's `reaction` rows. None on one thread
        (the pair adds to j directly)."""
        if not self.parallel:
            return {}
        columns = {"force": 0}
        for kind in ("tangential", "rolling"):
            if self.law(kind) is not None:
                columns[kind] = 3 * len(columns)
        return columns

    @property
    def reaction_width(self) -> int:
        return 3 * len(self.reaction_columns())

    @property
    def history_width(self) -> int:
        """Doubles stored per contact (3 for the shear displacement, 3 for the EPSD2 rolling torque)."""
        return sum(law.history for law in self.laws())


# ---------------------------------------------------------------- templates

_BLOCK_SLOT = re.compile(r"^(?P<indent>[ ]*)\$\{(?P<name>\w+)\}[ ]*$", re.M)


def render(template: str, **slots) -> str:
    """template with its slots filled (module docstring); every slot must be given."""
    def block(m):
        code = slots[m["name"]]
        return "\n".join(m["indent"] + line if line.strip() else "" for line in code.splitlines())
    return string.Template(_BLOCK_SLOT.sub(block, template)).substitute(slots)


#: force of one contact on i; the geometry (d, en*, vr*, vn, reff, meff, ...) is computed by the loop around it
CONTACT = """\
${normal}
${limit_force}
${cohesion}
fx = fn * enx
fy = fn * eny
fz = fn * enz
${tangential}
${rolling}
fix += fx
fiy += fy
fiz += fz
${reaction}
"""

#: the lever is the contact radius r - d/2 (LIGGGHTS 3.8 surface_model_default.h; at walls too, confirmed by
#: the cross-code case wall_oblique); a wall does not spin
SLIP = {False: """\
cri = ri - 0.5 * d
crj = rj - 0.5 * d
wrx = cri * wix + crj * omega[j, 0]
wry = cri * wiy + crj * omega[j, 1]
wrz = cri * wiz + crj * omega[j, 2]
vtx, vty, vtz = slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz)
""", True: """\
cri = ri - 0.5 * d
wrx = cri * wix
wry = cri * wiy
wrz = cri * wiz
vtx, vty, vtz = slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz)
"""}

#: the force of the slot acts at the contact point: torque -cr (en x Ft) on both partners (physics.md)
TANGENTIAL = """\
${damping}
${slip}
${law}
fx += ftx
fy += fty
fz += ftz
tqx = -(eny * ftz - enz * fty)
tqy = -(enz * ftx - enx * ftz)
tqz = -(enx * fty - eny * ftx)
tix += cri * tqx
tiy += cri * tqy
tiz += cri * tqz
${partner}
"""
TANGENTIAL_PARTNER = {True: "reaction[q, ${o}] = crj * tqx\nreaction[q, ${o1}] = crj * tqy\nreaction[q, ${o2}] = crj * tqz\n",
                      False: "torque[j, 0] += crj * tqx\ntorque[j, 1] += crj * tqy\ntorque[j, 2] += crj * tqz\n"}

RELATIVE_SPIN = {False: "wrelx = wix - omega[j, 0]\nwrely = wiy - omega[j, 1]\nwrelz = wiz - omega[j, 2]\n",
                 True: "wrelx = wix\nwrely = wiy\nwrelz = wiz\n"}
ROLLING = """\
${spin}
${law}
tix -= rtx
tiy -= rty
tiz -= rtz
${partner}
"""
ROLLING_PARTNER = {True: "reaction[q, ${o}] = rtx\nreaction[q, ${o1}] = rty\nreaction[q, ${o2}] = rtz\n",
                   False: "torque[j, 0] += rtx\ntorque[j, 1] += rty\ntorque[j, 2] += rtz\n"}

#: j takes the opposite force (Newton's third law). On several threads the pair leaves it in its row of
#: `reaction` and j adds it up in the particle pass; on one thread i subtracts it from f[j] at once - the same
#: operations on the same sums in the same order, so the same bytes. A wall takes it too (the force users can
#: print), collected at the last step of a chunk.
PAIR_REACTION = {True: "reaction[q, 0] = fx\nreaction[q, 1] = fy\nreaction[q, 2] = fz\n",
                 False: "f[j, 0] -= fx\nf[j, 1] -= fy\nf[j, 2] -= fz\n"}
#: and the torque about the origin of the force on the particle at the contact point c (the wall takes the
#: opposite). A plane or cylinder has one contact per particle; a mesh adds up its triangles' contacts.
WALL_REACTION = """\
${point}
if record:
    wall_part[i, w, 0] ${op} fx
    wall_part[i, w, 1] ${op} fy
    wall_part[i, w, 2] ${op} fz
    wall_tpart[i, w, 0] ${op} cy * fz - cz * fy
    wall_tpart[i, w, 1] ${op} cz * fx - cx * fz
    wall_tpart[i, w, 2] ${op} cx * fy - cy * fx
"""
#: the contact point of a plane or cylinder: the foot of the particle's centre on the surface
WALL_POINT = "cx = xi0 - enx * dist\ncy = xi1 - eny * dist\ncz = xi2 - enz * dist\n"

PARTICLE_HEAD = """\
xi0 = x[i, 0]
xi1 = x[i, 1]
xi2 = x[i, 2]
vix = v[i, 0]
viy = v[i, 1]
viz = v[i, 2]
wix = omega[i, 0]
wiy = omega[i, 1]
wiz = omega[i, 2]
ri = radius[i]
mi = mass[i]
ti = ptype[i]
fix = 0.0
fiy = 0.0
fiz = 0.0
tix = 0.0
tiy = 0.0
tiz = 0.0
"""

#: contact history is reset as soon as a contact opens (physically clean; see engine/README.md)
RESET_HISTORY = "for h in range(${width}):\n    ${target} = 0.0\n"

#: pass 1 of a force evaluation: each listed pair once, by its first particle i (i < j). On several threads
#: i's own sum goes into f[i] and torque[i] and what j takes stays in the pair's row of `reaction` (zeros for a
#: pair not in contact, so that pass 2 adds every row without a branch: x - (+0.0) and y + (+0.0) leave every
#: sum bitwise as it is, since sums that start at +0.0 or m g never become -0.0): every iteration writes only
#: rows of its own particle and its own pairs, no two threads write the same memory. On one thread i adds to
#: j directly, in the same order (the former serial loop).
PAIR_FORCES = '''\
@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies}):
    """Contact forces of the listed pairs (half list: each pair once, by i < j)."""
    ${unpack}
    ${same_body_head}
    nbr_start = nbr.start
    nbr_j = nbr.j
    pair_hist = nbr.hist
    rslot = nbr.rslot
    reaction = nbr.reaction
    for i in prange(n):
        ${particle_head}
        ${body_i}
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            dx = xi0 - x[j, 0]
            dy = xi1 - x[j, 1]
            dz = xi2 - x[j, 2]
            ${periodic_image}
            rsq = dx * dx + dy * dy + dz * dz
            rj = radius[j]
            radsum = ri + rj
            ${row}
            ${same_body}
            if rsq >= radsum * radsum:
                ${reset_history}
                ${zero_row}
                continue
            r = sqrt(rsq)
            enx = dx / r
            eny = dy / r
            enz = dz / r
            d = radsum - r
            mj = mass[j]
            tj = ptype[j]
            meff = mi * mj / (mi + mj)
            reff = ri * rj / radsum
            vrx = vix - v[j, 0]
            vry = viy - v[j, 1]
            vrz = viz - v[j, 2]
            vn = vrx * enx + vry * eny + vrz * enz
            ${contact}
        ${own_sum}
'''

#: a wall has infinite radius and mass (R* = r_i, m* = m_i), its type's material; en points from the wall to
#: the particle. A plane along an axis gives bitwise the values of a plane that knows its axis: (x - p).n adds
#: exact zeros, and + 0.0 turns the -0.0 of sign * 0.0 into +0.0.
PLANE_CONTACTS = """\
near = plane_near[i]
for w in range(nplanes):
    if w < PLANE_BITS and (near >> w) & 1 == 0:
        continue  # out of reach since the last rebuild: no contact, no history (PLANE_REACH)
    nx = plane_normal[w, 0]
    ny = plane_normal[w, 1]
    nz = plane_normal[w, 2]
    sep = (xi0 - plane_point[w, 0]) * nx + (xi1 - plane_point[w, 1]) * ny + (xi2 - plane_point[w, 2]) * nz
    dist = abs(sep)
    if dist >= ri:
        ${reset_history}
        continue
    ${bounds}
    sign = 1.0 if sep >= 0.0 else -1.0
    enx = sign * nx + 0.0
    eny = sign * ny + 0.0
    enz = sign * nz + 0.0
    d = ri - dist
    tj = plane_type[w]
    vrx = vix - plane_vel[w, 0]
    vry = viy - plane_vel[w, 1]
    vrz = viz - plane_vel[w, 2]
    vn = vrx * enx + vry * eny + vrz * enz
    ${contact}
"""
#: the planes a particle can touch before the next rebuild: its centre at the last rebuild (x_build) nearer than
#: r + skin to the plane, since it moves at most skin/2 before the next rebuild (bit w of plane_near[i] for the
#: first PLANE_BITS planes; planes after them, and planes moving along their normal, are always tested). A plane
#: out of reach has no contact at any force evaluation until the next rebuild, so its history is zero: set
#: here once, as each of those evaluations would set it. Recomputed after every rebuild and at every start of
#: run_steps (walls may have changed between runs), from x_build: the same bits on any thread count and after
#: a restart.
PLANE_REACH = '''\
@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def plane_reach(s, n, walls, skin, plane_near):
    """Bits of the planes within r + skin of each particle's centre at the last rebuild (see the template)."""
    x_build = s.x_build
    radius = s.radius
    wall_hist = s.wall_hist
    plane_point = walls.plane_point
    plane_normal = walls.plane_normal
    plane_vel = walls.plane_vel
    nplanes = min(plane_point.shape[0], PLANE_BITS)
    for i in prange(n):
        near = 0
        reach = radius[i] + skin
        for w in range(nplanes):
            nx = plane_normal[w, 0]
            ny = plane_normal[w, 1]
            nz = plane_normal[w, 2]
            moving = plane_vel[w, 0] * nx + plane_vel[w, 1] * ny + plane_vel[w, 2] * nz != 0.0
            sep = ((x_build[i, 0] - plane_point[w, 0]) * nx + (x_build[i, 1] - plane_point[w, 1]) * ny
                   + (x_build[i, 2] - plane_point[w, 2]) * nz)
            if moving or abs(sep) < reach:
                near |= 1 << w
            else:
                for h in range(wall_hist.shape[2]):
                    wall_hist[i, w, h] = 0.0
        plane_near[i] = near
'''
PLANE_REACH_CALL = "plane_near = np.empty(n, dtype=np.int64)\nplane_reach(s, n, walls, skin, plane_near)\n"

#: a bounded plane: contact only where the foot of the centre lies in the box lo..hi
PLANE_BOUNDS = """\
fx0 = xi0 - sep * nx
fx1 = xi1 - sep * ny
fx2 = xi2 - sep * nz
if (fx0 < plane_lo[w, 0] or fx0 > plane_hi[w, 0] or fx1 < plane_lo[w, 1] or fx1 > plane_hi[w, 1]
        or fx2 < plane_lo[w, 2] or fx2 > plane_hi[w, 2]):
    ${reset_history}
    continue
"""
#: en points inward for an inside wall, outward outside; rho the distance from the axis (for the z axis through
#: (cx, cy, 0) bitwise sqrt((x - cx)^2 + (y - cy)^2))
CYLINDER_CONTACTS = """\
for q in range(cyl_radius.shape[0]):
    w = nplanes + q
    px = xi0 - cyl_point[q, 0]
    py = xi1 - cyl_point[q, 1]
    pz = xi2 - cyl_point[q, 2]
    ax = cyl_axis[q, 0]
    ay = cyl_axis[q, 1]
    az = cyl_axis[q, 2]
    along = px * ax + py * ay + pz * az
    ${extent}
    rx = px - along * ax
    ry = py - along * ay
    rz = pz - along * az
    rho = sqrt(rx * rx + ry * ry + rz * rz)
    if cyl_side[q] > 0:
        dist = cyl_radius[q] - rho
    else:
        dist = rho - cyl_radius[q]
    if dist >= ri or rho == 0.0:
        ${reset_history}
        continue
    enx = -cyl_side[q] * rx / rho + 0.0
    eny = -cyl_side[q] * ry / rho + 0.0
    enz = -cyl_side[q] * rz / rho + 0.0
    d = ri - dist
    tj = cyl_type[q]
    ${surface_velocity}
    vn = vrx * enx + vry * eny + vrz * enz
    ${contact}
"""
CYLINDER_EXTENT = """\
if along < cyl_lo[q] or along > cyl_hi[q]:
    ${reset_history}
    continue
"""
#: a turning cylinder's surface moves at omega R (axis x radial unit vector) at the contact point
CYLINDER_SPIN = """\
spin = cyl_omega[q] * cyl_radius[q] / rho
vrx = vix - spin * (ay * rz - az * ry)
vry = viy - spin * (az * rx - ax * rz)
vrz = viz - spin * (ax * ry - ay * rx)
"""
CYLINDER_STILL = "vrx = vix\nvry = viy\nvrz = viz\n"

#: the triangles in particle i's rows of the mesh list (engine/mesh.py): closest point, region, and whether an
#: edge or corner contact counts; a face contact has the face normal (as a plane), an edge or corner contact
#: the direction from the closest point c to the centre
MESH_CONTACTS = """\
for k in range(mesh_start[i], mesh_start[i + 1]):
    t = mesh_tri[k]
    cx, cy, cz, region = closest_point(xi0, xi1, xi2, tri_v, t)
    # every name below is set on every path: Numba's parallel loops treat a name that some path leaves unset
    # as shared between threads
    gx = xi0 - cx
    gy = xi1 - cy
    gz = xi2 - cz
    nx = tri_n[t, 0]
    ny = tri_n[t, 1]
    nz = tri_n[t, 2]
    sep = (xi0 - tri_v[t, 0, 0]) * nx + (xi1 - tri_v[t, 0, 1]) * ny + (xi2 - tri_v[t, 0, 2]) * nz
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
WALLS = """\
${particle_head}
reff = ri
meff = mi
${planes}
${cylinders}
${meshes}
f[i, 0] += fix
f[i, 1] += fiy
f[i, 2] += fiz
torque[i, 0] += tix
torque[i, 1] += tiy
torque[i, 2] += tiz
"""

#: fix nve/sphere: half kick of v and omega (I = 0.4 m r^2), drift; then the neighbor check (moved more than
#: skin/2: rebuild; a non-finite position fails every comparison: the run stops naming the particle). On one
#: thread the force and torque, read for the last time here, start the next evaluation (gravity, zero) in the
#: same pass: no separate pass over the particles to clear them
DRIFT = """\
for a in range(3):
    v[i, a] += half_dt * f[i, a] * inv_mass[i]
    x[i, a] += dt * v[i, a]
    omega[i, a] += half_dt * torque[i, a] * inv_inertia[i]
${clear}
dx = x[i, 0] - x_build[i, 0]
dy = x[i, 1] - x_build[i, 1]
dz = x[i, 2] - x_build[i, 2]
d2 = dx * dx + dy * dy + dz * dz
if d2 > half_skin_sq:
    need += 1
elif not d2 <= half_skin_sq:
    bad = min(bad, i)
"""

#: pass 2 of a force evaluation, per particle: on several threads gravity (F = m g, the first force), minus
#: what the pairs (i, p) left for p in `reaction` - added in increasing i, exactly the order of the serial
#: loop - plus p's own pair sum; then walls, the second half kick and (but at a chunk's last step) the next
#: step's first half kick and drift. Returns (particles beyond skin/2, first non-finite position or n).
PARTICLE_PASS = '''\
@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, kick, drift, record, wall_part, wall_tpart,
                  half_skin_sq, plane_near):
    """Forces from the pair rows, walls, integration; see the template in engine.kernels."""
    ${unpack}
    ${unpack_walls}
    mesh_start = mnbr.start
    mesh_tri = mnbr.tri
    mesh_hist = mnbr.hist
    mesh_touch = mnbr.touch
    rstart = nbr.rstart
    reaction = nbr.reaction
    half_dt = 0.5 * dt
    need = 0
    bad = n
    for i in prange(n):
        ${gather}
        ${walls}
        if kick:
            for a in range(3):
                v[i, a] += half_dt * f[i, a] * inv_mass[i]
                omega[i, a] += half_dt * torque[i, a] * inv_inertia[i]
        if drift:
            ${drift}
    return need, bad


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def drift_pass(s, n, dt, half_skin_sq, gravity):
    """The first half kick and drift of a chunk's first step. Returns (beyond skin/2, first bad or n)."""
    ${unpack}
    half_dt = 0.5 * dt
    need = 0
    bad = n
    for i in prange(n):
        ${drift}
    return need, bad
'''

#: several threads: gravity (F = m g, the first force), minus what the pairs (i, p) left for p, in increasing i,
#: plus p's own pair sum (pass 1 put it into f[p] and torque[p])
GATHER = """\
${clear}
gtx = 0.0
gty = 0.0
gtz = 0.0
for q in range(rstart[i], rstart[i + 1]):
    gfx -= reaction[q, 0]
    gfy -= reaction[q, 1]
    gfz -= reaction[q, 2]
    ${gather_torque}
f[i, 0] = gfx + f[i, 0]
f[i, 1] = gfy + f[i, 1]
f[i, 2] = gfz + f[i, 2]
torque[i, 0] = gtx + torque[i, 0]
torque[i, 1] = gty + torque[i, 1]
torque[i, 2] = gtz + torque[i, 2]
"""
#: the end of particle i's pairs: its own sum, stored (several threads) or added to what the pairs (i', i),
#: i' < i, already subtracted from f[i] (one thread)
OWN_SUM = {True: "f[i, 0] = fix\nf[i, 1] = fiy\nf[i, 2] = fiz\ntorque[i, 0] = tix\ntorque[i, 1] = tiy\ntorque[i, 2] = tiz\n",
           False: "f[i, 0] += fix\nf[i, 1] += fiy\nf[i, 2] += fiz\ntorque[i, 0] += tix\ntorque[i, 1] += tiy\n"
                  "torque[i, 2] += tiz\n"}
#: one thread: forces start at gravity (F = m g) before the pairs add to them
CLEAR_FORCES = '''\
@njit(cache=True, error_model="numpy")
def clear_forces(s, n, gravity):
    f = s.f
    torque = s.torque
    mass = s.mass
    for i in range(n):
        ${clear}
        torque[i, 0] = 0.0
        torque[i, 1] = 0.0
        torque[i, 2] = 0.0
'''

#: the force the particles exert on each wall: the contributions of the particles in increasing index (the
#: order of a serial loop), only at steps where Python reads it
WALL_FORCE_SUM = """\
if record:
    wall_force = walls.force
    wall_torque = walls.torque
    wall_force[:, :] = 0.0
    wall_torque[:, :] = 0.0
    for i in range(n):
        for w in range(wall_part.shape[1]):
            for a in range(3):
                wall_force[w, a] -= wall_part[i, w, a]
                wall_torque[w, a] -= wall_tpart[i, w, a]
"""

STEP_LOOP = '''\
@njit(cache=True, error_model="numpy")
def setup(s, n, nbr, mnbr, walls, pp, c, step, lost${bodies}):
    """Fresh neighbor lists and forces for the current state (start of a run after the scene changed).
    Returns (particles kept, neighbor list, mesh contact list)."""
    ${constants}
    box = hi - lo
    n, nbr = rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost)
    ${mesh_rebuild}
    ${plane_reach_start}
    ${clear_forces}
    pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies})
    record = True
    wall_part = np.zeros((n, ${nwalls}, 3))
    wall_tpart = np.zeros((n, ${nwalls}, 3))
    particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, False, False, record, wall_part, wall_tpart,
                  0.0, plane_near)
    ${body_setup}
    ${wall_force_sum}
    return n, nbr, mnbr


@njit(cache=True, error_model="numpy")
def run_steps(s, n, nbr, mnbr, walls, pp, c, step0, nsteps, timers, lost${bodies}):
    """nsteps Velocity-Verlet steps (fix nve/sphere order) of the first n particles of state s. Returns
    (status, bad particle, steps done, rebuilds, particles kept, neighbor list, mesh contact list); status 1 =
    non-finite position. timers += [neigh, pair, modify] in s."""
    ${constants}
    box = hi - lo
    half_skin_sq = 0.25 * skin * skin
    status = 0
    bad = -1
    done = 0
    rebuilds = 0
    if nsteps == 0:
        return status, bad, done, rebuilds, n, nbr, mnbr
    t0 = now()
    ${plane_reach_start}
    need, first_bad = drift_pass(s, n, dt, half_skin_sq, gravity)
    ${body_start}
    neigh = 0.0
    pair = 0.0
    modify = now() - t0
    for k_step in range(nsteps):
        step = step0 + k_step + 1
        t0 = now()
        ${move_walls}
        if first_bad < n:
            status = 1
            bad = first_bad
            break
        t1 = now()
        ${mesh_travel}
        if need > 0:
            n, nbr = rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost)
            ${mesh_rebuild}
            ${plane_reach}
            rebuilds += 1
        t2 = now()
        pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies})
        t3 = now()
        record = k_step == nsteps - 1
        wall_part = np.zeros((n if record else 0, ${nwalls}, 3))
        wall_tpart = np.zeros((n if record else 0, ${nwalls}, 3))
        need, first_bad = particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, True, not record, record,
                                        wall_part, wall_tpart, half_skin_sq, plane_near)
        ${body_step}
        ${wall_force_sum}
        t4 = now()
        neigh += t2 - t1
        pair += t3 - t2
        modify += (t1 - t0) + (t4 - t3)
        done += 1
    timers[0] += neigh
    timers[1] += pair
    timers[2] += modify
    return status, bad, done, rebuilds, n, nbr, mnbr
'''

CONSTANTS = """\
dt = c.dt
char_vel = c.characteristic_velocity
gravity = c.gravity
lo = c.lo
hi = c.hi
periodic = c.periodic
skin = c.skin
"""

#: the planes' points move with their velocity (each step, as LIGGGHTS' fix wall/gran moves its walls)
MOVE_PLANES = """\
for w in range(walls.plane_point.shape[0]):
    for a in range(3):
        walls.plane_point[w, a] += walls.plane_vel[w, a] * dt
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

MODULE = '''\
"""Generated by engine.kernels for ${combination}; do not edit."""
from math import sqrt

import numpy as np
from numba import prange

from engine.clock import now
from engine.jit import njit
from engine.neighbor import PARALLEL, rebuild
${imports}

#: planes whose reach is kept as bits of one int64 per particle (plane_reach)
PLANE_BITS = 62


${pair_forces}


${particle_pass}


${clear_forces}


${plane_reach}


${step_loop}
'''


# ---------------------------------------------------------------- filling the slots

def _unpack(obj: str, fields) -> str:
    """Fields of a state object as locals. Numba (0.68, issues 5872/7135) loses writes made through a
    namedtuple's attribute inside a parallel loop; locals are safe everywhere."""
    return "".join(f"{name} = {obj}.{name}\n" for name in fields)


#: where a contact's history lives: pair k of the neighbor list, particle i's dense row of wall w, entry k of the
#: sparse mesh contact list
HISTORY = {"pair": "pair_hist[k, {h}]", "wall": "wall_hist[i, w, {h}]", "mesh": "mesh_hist[k, {h}]"}


def _law_call(c: Combination, law, place: str) -> str:
    """The law's call with its parameter columns and history slots filled in (place: pair, wall or mesh)."""
    columns = c.parameter_columns()
    offset = c.history_offsets().get(law.submodel, 0)
    names = {p: f"pp[ti, tj, {columns[p]}]" for p in law.parameters}
    names.update({f"h{k}": HISTORY[place].format(h=offset + k) for k in range(law.history)})
    return (law.pair if place == "pair" else law.wall_call).format(**names) + "\n"


def contact_code(c: Combination, place: str) -> str:
    """The force of one pair (place "pair") or particle-wall contact (a plane or cylinder: "wall", a mesh
    triangle: "mesh"), for the named laws only."""
    tangential, rolling = c.law("tangential"), c.law("rolling")
    cohesion = c.law("cohesion")
    columns = c.reaction_columns()
    wall = place != "pair"
    tangential_code = rolling_code = ""

    def partner(templates, submodel):
        if wall:
            return ""
        o = columns.get(submodel, 0)
        return render(templates[c.parallel], o=str(o), o1=str(o + 1), o2=str(o + 2))

    if tangential is not None:
        tangential_code = render(TANGENTIAL, damping="" if c.tangential_damping else "gt = 0.0",
                                 slip=SLIP[wall] if "slip" in tangential.needs else "",
                                 law=_law_call(c, tangential, place), partner=partner(TANGENTIAL_PARTNER, "tangential"))
    if rolling is not None:
        rolling_code = render(ROLLING, spin=RELATIVE_SPIN[wall] if "relative_spin" in rolling.needs else "",
                              law=_law_call(c, rolling, place), partner=partner(ROLLING_PARTNER, "rolling"))
    if place == "pair":
        reaction = PAIR_REACTION[c.parallel]
    else:  # a mesh adds up the contacts of its triangles; its contact point comes from the triangle
        reaction = render(WALL_REACTION, op="+=" if place == "mesh" else "=",
                          point="" if place == "mesh" else WALL_POINT)
    return render(CONTACT, normal=_law_call(c, c.law("normal"), place),
                  limit_force="fn = max(fn, 0.0)" if c.limit_force else "",
                  cohesion=_law_call(c, cohesion, place) if cohesion is not None else "",
                  tangential=tangential_code, rolling=rolling_code, reaction=reaction)


def _reset_history(c: Combination, place: str) -> str:
    if c.history_width == 0:
        return ""
    return render(RESET_HISTORY, width=str(c.history_width), target=HISTORY[place].format(h="h"))


def generate_source(c: Combination) -> str:
    """Python source of the compiled kernels for combination c."""
    periodic = "".join(f"d{name} -= box[{a}] * np.rint(d{name} / box[{a}])\n"
                       for a, name in enumerate("xyz") if c.periodic[a])
    unpack = _unpack("s", FIELD_NAMES)
    rows = c.parallel  # several threads: pair rows for the partner, gathered in the particle pass
    zero_row = f"for h in range({c.reaction_width}):\n    reaction[q, h] = 0.0" if rows else ""
    # clumps (engine/clumps.py): two members of one body do not touch; the bodies' pass follows the particles'
    body_slots = dict(bodies=", bodies", body_setup=clumps.BODY_SETUP, body_start=clumps.BODY_START,
                      body_step=clumps.BODY_STEP) if c.clumps else dict(bodies="", body_setup="", body_start="",
                                                                         body_step="")
    pair_forces = render(PAIR_FORCES, unpack=unpack, particle_head=PARTICLE_HEAD, periodic_image=periodic,
                         row="q = rslot[k]" if rows else "", reset_history=_reset_history(c, "pair"),
                         zero_row=zero_row, contact=contact_code(c, "pair"), own_sum=OWN_SUM[rows],
                         bodies=body_slots["bodies"],
                         same_body_head=clumps.SAME_BODY_HEAD if c.clumps else "",
                         body_i="body_i = member_body[pid[i]]" if c.clumps else "",
                         same_body=render(clumps.SAME_BODY, zero_row=zero_row) if c.clumps else "")
    has_walls = c.planes or c.cylinders or c.meshes
    walls = unpack_walls = ""
    if has_walls:
        contact, reset = contact_code(c, "wall"), _reset_history(c, "wall")
        planes = cylinders = meshes = ""
        if c.planes:
            bounds = render(PLANE_BOUNDS, reset_history=reset) if c.bounded_planes else ""
            planes = render(PLANE_CONTACTS, reset_history=reset, contact=contact, bounds=bounds)
        if c.cylinders:
            cylinders = render(CYLINDER_CONTACTS, reset_history=reset, contact=contact,
                               extent=render(CYLINDER_EXTENT, reset_history=reset) if c.cylinder_extent else "",
                               surface_velocity=CYLINDER_SPIN if c.cylinder_spin else CYLINDER_STILL)
        if c.meshes:
            width = str(c.history_width)
            meshes = render(MESH_CONTACTS, contact=contact_code(c, "mesh"),
                            take_history=render(MESH_TAKE_HISTORY, width=width) if c.history_width else "",
                            reset_history=render(MESH_RESET, width=width) if c.history_width else "",
                            surface_velocity=MESH_VELOCITY + (MESH_SPIN if c.mesh_rotation else ""))
        walls = render(WALLS, particle_head=PARTICLE_HEAD, planes=planes, cylinders=cylinders, meshes=meshes)
        unpack_walls = _unpack("walls", WALL_FIELDS[:-2]) + "nplanes = plane_point.shape[0]\n"
    if c.gravity:
        gravity_force = "mass[i] * gravity[0]", "mass[i] * gravity[1]", "mass[i] * gravity[2]"
    else:
        gravity_force = "0.0", "0.0", "0.0"
    gather = clear_forces = clear_call = ""
    if rows:
        gather_torque = "".join(f"gtx += reaction[q, {o}]\ngty += reaction[q, {o + 1}]\ngtz += reaction[q, {o + 2}]\n"
                                for name, o in c.reaction_columns().items() if name != "force")
        gather = render(GATHER, clear="".join(f"gf{a} = {g}\n" for a, g in zip("xyz", gravity_force)),
                        gather_torque=gather_torque)
    else:
        clear_forces = render(CLEAR_FORCES, clear="".join(f"f[i, {a}] = {g}\n" for a, g in enumerate(gravity_force)))
        clear_call = "clear_forces(s, n, gravity)"
    clear = "" if rows else ("".join(f"f[i, {a}] = {g}\n" for a, g in enumerate(gravity_force))
                             + "torque[i, 0] = 0.0\ntorque[i, 1] = 0.0\ntorque[i, 2] = 0.0\n")
    drift = render(DRIFT, clear=clumps.member_clear(clear) if c.clumps else clear)
    particle_pass = render(PARTICLE_PASS, unpack=unpack, unpack_walls=unpack_walls, gather=gather, walls=walls,
                           drift=drift)
    move_walls = (MOVE_PLANES if c.planes else "") + (
        render(MOVE_MESHES, place=PLACE_TURNING if c.mesh_rotation else PLACE_SHIFTED,
               turn="walls.mesh_angle[m] += walls.mesh_omega[m] * dt" if c.mesh_rotation else "") if c.mesh_motion
        else "")
    step_loop = render(STEP_LOOP, constants=CONSTANTS, move_walls=move_walls,
                       mesh_travel=MESH_TRAVEL if c.mesh_motion else "",
                       mesh_rebuild=MESH_REBUILD if c.meshes else "",
                       nwalls="walls.force.shape[0]" if has_walls else "0", clear_forces=clear_call,
                       wall_force_sum=WALL_FORCE_SUM if has_walls else "",
                       plane_reach=PLANE_REACH_CALL if c.planes else "",
                       plane_reach_start=PLANE_REACH_CALL if c.planes else "plane_near = np.empty(0, dtype=np.int64)",
                       **body_slots)
    called = sorted({fn for law in c.laws() for fn in law.functions}, key=lambda fn: fn.__name__)
    body = pair_forces + particle_pass + step_loop
    if "slip_velocity(" in body:
        from .contact_laws import slip_velocity
        called.append(slip_velocity)
    if c.meshes:  # the mesh geometry (engine/mesh.py) only where a scene has meshes
        from . import mesh
        called += [mesh.closest_point, mesh.edge_or_corner_counts, mesh.mesh_rebuild, mesh.place_vertices,
                   mesh.shift_vertices, mesh.take_coplanar_history]
    if c.clumps:
        called.append(clumps.body_pass)
    imports = "".join(f"from {fn.__module__} import {fn.__name__}\n" for fn in called if fn.__name__ + "(" in body)
    source = render(MODULE, combination=repr(c), imports=imports, pair_forces=pair_forces,
                    particle_pass=particle_pass, clear_forces=clear_forces, step_loop=step_loop,
                    plane_reach=PLANE_REACH if c.planes else "")
    # one thread: the loops compiled serially (prange is range there)
    return source if c.parallel else source.replace("parallel=PARALLEL", "parallel=False")


def parameter_table(c: Combination, materials: dict, interactions: dict, ntypes: int):
    """pp[ti, tj, column] for 0-based types ti, tj < ntypes (user types 1..ntypes; see seed 000 on
    off-by-one), with the columns of `Combination.parameter_columns` (the parameters the named laws read).

    Pairs without an interaction keep NaN in the columns that need one, so using one by mistake shows up as
    non-finite values.
    """
    import numpy as np

    columns = c.parameter_columns()
    pp = np.full((ntypes, ntypes, len(columns)), np.nan)
    for a in range(1, ntypes + 1):
        for b in range(1, ntypes + 1):
            if a not in materials or b not in materials:
                continue
            inter = interactions.get((min(a, b), max(a, b)))
            for name, k in columns.items():
                parameter = PARAMETERS[name]
                if inter is not None or not parameter.needs_interaction:
                    pp[a - 1, b - 1, k] = parameter.value(materials[a], materials[b], inter)
    return pp


# ---------------------------------------------------------------- building and caching

_loaded: dict = {}


def build_kernel(c: Combination):
    """The compiled module (functions setup, run_steps) for combination c; generated and cached on disk."""
    if c in _loaded:
        return _loaded[c]
    source = generate_source(c)
    # the file is named by its text; the machine code of each function in it is keyed by its content and the
    # functions it calls (engine/jit.py): a commit that leaves both alone compiles nothing
    key = hashlib.sha256(source.encode()).hexdigest()[:20]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"dem_kernel_{key}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)  # atomic: parallel runs never import a half-written file
    name = f"dem_kernel_{key}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _loaded[c] = module
    return module
