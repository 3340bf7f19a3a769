"""Superquadric particles: rigid convex bodies (|x/a|^n2 + |y/b|^n2)^(n1/n2) + |z/c|^n1 <= 1.

Half-axes a, b, c (m) along the body frame's axes, blockiness n1 (along z) and n2 (in the x-y plane), each
from 2 (an ellipsoid; a sphere when a = b = c) to about 10 (nearly a box). Barr's superquadric (Barr, IEEE
CG&A 1 (1981) 11-23) in the notation of Podlozhnyuk, Pirker and Kloss, Comp. Part. Mech. 4 (2017) 101-118.

They are bodies of their own, not particles of the sphere state (engine/state.py): a scene of spheres keeps
its kernels (the step loop of engine/kernels.py calls `superquadric_pass` only where a scene has
superquadrics: slots ``${sq_*}``). What this module holds:

- **mass properties** in closed form with the beta function (`mass_properties`, Jaklic, Leonardis and Solina,
  *Segmentation and Recovery of Superquadrics*, Kluwer 2000, chapter 2.5);
- **support points** (the point of the body farthest along a direction) in closed form (`support_point`): the
  superquadric is the unit ball of a nested norm of (x/a, y/b, z/c), whose dual norm is the nested norm with
  the conjugate exponents q = n / (n - 1);
- **contact detection**: the overlap of two convex bodies along a unit normal n (pointing from j to i) is
  d(n) = h_j(n) + h_i(-n), h the support function; the penetration depth is its minimum over n (the
  separating-axis theorem for convex bodies; van den Bergen, *Collision Detection in Interactive 3D
  Environments*, 2003, section 4.3.5). Its gradient is w = p_j(n) - p_i(-n), the vector between the two
  support points, so at the minimum w is parallel to n: the two surface points have opposite normals along
  their connecting line, the contact condition of Podlozhnyuk et al. 2017. `pair_contact` minimises d(n) on
  the unit sphere by Newton's method in the tangent plane (Hessian by differences of w, backtracking line
  search; it stops when the gradient or the decrease of d becomes negligible), from the last step's normal of
  the contact (a new contact: the best of the line of centres and the bodies' axis directions), after a
  bounding-sphere check; d < 0 along any direction tried is a separating axis: no contact. For a plane of
  normal m the support point along -m is the deepest point, in closed form.
- **the contact force**: the engine's Hertz or Hooke normal law and its tangential laws (engine/contact_laws.py)
  at the midpoint c of the two support points, with the equivalent radius R* = R_i R_j / (R_i + R_j) of the
  mean-curvature radii R = 2 / (k1 + k2) of the two surfaces at their support points (`curvature_radius`;
  Podlozhnyuk et al. 2017 take the equivalent radius from the surface curvature at the contact point), each
  at most max(a, b, c)^2 / min(a, b, c) - the largest radius of an ellipsoid of these half-axes - since the
  faces of a blocky body are flat (k = 0) at their centres. The torque on i is (c - x_i) x F.
- **integration**: velocity Verlet for the centre of mass and the angular momentum, the clumps' Richardson
  iteration for the orientation quaternion (engine/clumps.py `rotate`: one home for that rule).

Contacts: superquadric-superquadric (every pair whose bounding spheres overlap, found through a cell grid
rebuilt every step: O(N)), superquadric-plane and superquadric-mesh triangle (`_mesh_forces`).
Spheres and cylinders do not touch superquadrics (the run refuses such scenes, engine/runner.py).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from . import clumps
from .contact_laws import (effective_youngs_modulus, hertz_normal, hooke_normal, tangential_history,
                           tangential_no_history)
from .jit import njit
from .models import PARAMETERS
from .mesh import closest_point
from .walls import surface_speeds

#: contacts a superquadric keeps history for with partners of higher index (pairs are held by their lower index)
SLOTS = 16
#: per contact slot: shear displacement (3, m) and the last normal (3) that starts the next Newton search
SLOT_WIDTH = 6
#: mesh contacts a superquadric keeps history for (one per plane of touching triangles, or per edge or corner)
MESH_SLOTS = 8

Superquadrics = namedtuple("Superquadrics", [
    "x", "v", "q", "angmom", "omega", "inertia", "mass", "shape", "radius", "rcap", "ptype", "sid", "force",
    "torque", "partner", "hist", "wall_hist", "mesh_tri", "mesh_hist", "rot", "status"])
Superquadrics.__doc__ = (
    "Superquadric bodies: centre x (m), velocity v (m/s), orientation q (w, x, y, z; body frame -> space), "
    "angular momentum (kg m^2/s, space frame), angular velocity omega (rad/s, space frame), principal moments "
    "inertia (kg m^2, about the body axes x, y, z), mass (kg), shape (a, b, c in m, n1, n2), bounding radius "
    "(m), curvature radius cap rcap (m), type (0-based), id (from 1), force (N) and torque (N m) of the last "
    "force evaluation, per contact slot the partner index (-1: free) and history, per plane the wall history "
    "(shear displacement, m), per mesh contact slot its triangle (-1: free) and history (shear displacement, m; "
    "contact normal), rotation matrices (work space), status [slots overflowed].")

#: per type pair, the columns the superquadric contact reads (engine/models.py PARAMETERS: one home for them)
LAW_COLUMNS = ("ystar", "gstar", "beta", "log_e", "friction")
#: the contact model as numbers: pp[ti, tj, LAW_COLUMNS], normal (0 hertz, 1 hooke), tangential (0 none,
#: 1 no_history, 2 history), limit_force, tangential_damping (booleans as 0/1)
Laws = namedtuple("Laws", ["pp", "normal", "tangential", "limit_force", "tangential_damping"])
NORMAL_LAWS = {"hertz": 0, "hooke": 1}
TANGENTIAL_LAWS = {"none": 0, "no_history": 1, "history": 2}

#: Newton search of the contact normal: iterations; it stops when the tangential gradient is below this
#: fraction of the bodies' size, or an iteration lowers the depth by less than this fraction of itself (a
#: blocky body's edge is nearly a kink of d(n), where the gradient never vanishes and the steps stay small:
#: the depth is then known to about that fraction, the Hertz force to 1.5 times it); angle of the difference
#: step (rad); halvings of a step that does not decrease the depth
MAX_ITERATIONS = 40
GRADIENT_TOLERANCE = 1e-13
DEPTH_TOLERANCE = 1e-8
DIFFERENCE_STEP = 1e-6
HALVINGS = 30


def empty(planes: int = 0) -> Superquadrics:
    return Superquadrics(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4)), np.zeros((0, 3)), np.zeros((0, 3)),
                         np.zeros((0, 3)), np.zeros(0), np.zeros((0, 5)), np.zeros(0), np.zeros(0),
                         np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 3)),
                         np.zeros((0, 3)), np.zeros((0, SLOTS), dtype=np.int64), np.zeros((0, SLOTS, SLOT_WIDTH)),
                         np.zeros((0, planes, 3)), np.zeros((0, MESH_SLOTS), dtype=np.int64),
                         np.zeros((0, MESH_SLOTS, 6)), np.zeros((0, 3, 3)), np.zeros(1, dtype=np.int64))


# ---------------------------------------------------------------- shape: mass properties


def beta_function(x: float, y: float) -> float:
    """B(x, y) = Gamma(x) Gamma(y) / Gamma(x + y)."""
    return math.exp(math.lgamma(x) + math.lgamma(y) - math.lgamma(x + y))


def mass_properties(a: float, b: float, c: float, n1: float, n2: float, density: float) -> dict:
    """Volume (m^3), mass (kg) and principal moments of inertia (kg m^2, about the body axes x, y, z through
    the centre) of a superquadric, in closed form (Jaklic, Leonardis and Solina 2000, eqs. 2.60 and 2.61, with
    e1 = 2 / n1, e2 = 2 / n2):

        V   = 2 a b c e1 e2 B(e1/2 + 1, e1) B(e2/2, e2/2)
        Ixx = rho a b c e1 e2 / 2 [b^2 B(3 e2/2, e2/2) B(e1/2, 2 e1 + 1) + 4 c^2 B(e2/2, e2/2 + 1) B(3 e1/2, e1 + 1)]
        Iyy = the same with a^2 for b^2
        Izz = rho a b c e1 e2 / 2 (a^2 + b^2) B(3 e2/2, e2/2) B(e1/2, 2 e1 + 1)

    (a sphere: 4/3 pi r^3 and 2/5 m r^2; tests/engine/test_superquadrics.py checks them against integration
    over a grid)."""
    e1, e2 = 2.0 / n1, 2.0 / n2
    volume = 2.0 * a * b * c * e1 * e2 * beta_function(e1 / 2 + 1, e1) * beta_function(e2 / 2, e2 / 2)
    common = 0.5 * density * a * b * c * e1 * e2
    planar = beta_function(1.5 * e2, e2 / 2) * beta_function(e1 / 2, 2 * e1 + 1)
    axial = 4.0 * c * c * beta_function(e2 / 2, e2 / 2 + 1) * beta_function(1.5 * e1, e1 + 1)
    moments = np.array([common * (b * b * planar + axial), common * (a * a * planar + axial),
                        common * (a * a + b * b) * planar])
    return dict(volume=volume, mass=density * volume, moments=moments)


# ---------------------------------------------------------------- shape: support points and curvature


@njit(cache=True, error_model="numpy")
def support_point(a, b, c, n1, n2, ux, uy, uz):
    """The point of the superquadric (body frame, m) farthest along the direction u (any length): the
    gradient of its support function h(u) = N*(a ux, b uy, c uz), N* the nested norm with the conjugate
    exponents q = n / (n - 1) (for n1 = n2 = 2 the ellipsoid's p = A^2 u / |A u|, A = diag(a, b, c))."""
    if n1 == 2.0 and n2 == 2.0:  # an ellipsoid: the same formula without powers (a quarter of the time)
        vx = a * ux
        vy = b * uy
        vz = c * uz
        h = np.sqrt(vx * vx + vy * vy + vz * vz)
        if h == 0.0:
            return 0.0, 0.0, 0.0
        return a * vx / h, b * vy / h, c * vz / h
    # the powers as exponentials of logarithms (log 0 = -inf, exp(-inf) = 0): 5 logarithms and 7
    # exponentials instead of 10 powers, twice as fast
    q1 = n1 / (n1 - 1.0)
    q2 = n2 / (n2 - 1.0)
    lx = np.log(abs(a * ux))
    ly = np.log(abs(b * uy))
    lz = np.log(abs(c * uz))
    planar = np.exp(q2 * lx) + np.exp(q2 * ly)  # rho_v^q2
    if planar == 0.0 and lz == -np.inf:
        return 0.0, 0.0, 0.0
    l_rho = np.log(planar) / q2
    lh = np.log(np.exp(q1 * l_rho) + np.exp(q1 * lz)) / q1
    pz = c * np.exp((q1 - 1.0) * (lz - lh))
    px = 0.0
    py = 0.0
    if planar > 0.0:
        outer = (q1 - 1.0) * (l_rho - lh)
        px = a * np.exp(outer + (q2 - 1.0) * (lx - l_rho))
        py = b * np.exp(outer + (q2 - 1.0) * (ly - l_rho))
    return (px if ux >= 0.0 else -px), (py if uy >= 0.0 else -py), (pz if uz >= 0.0 else -pz)


@njit(cache=True, error_model="numpy")
def curvature_radius(a, b, c, n1, n2, px, py, pz, cap):
    """The mean-curvature radius 2 / (k1 + k2) (m) of the superquadric's surface at its point p (body frame),
    at most cap. From the gradient g and Hessian H of the shape function F = u^(n1/n2) + |z/c|^n1,
    u = |x/a|^n2 + |y/b|^n2: k1 + k2 = (|g|^2 tr H - g.H g) / |g|^3 (Goldman, Computer Aided Geometric Design
    22 (2005) 632-658, eq. 4.3). A flat face (k = 0) gives the cap."""
    sx = 1.0 if px >= 0.0 else -1.0
    sy = 1.0 if py >= 0.0 else -1.0
    sz = 1.0 if pz >= 0.0 else -1.0
    xa = abs(px) / a
    yb = abs(py) / b
    zc = abs(pz) / c
    u = max(xa ** n2 + yb ** n2, 1e-100)  # on the z axis u = 0: its powers below meet zero factors
    e = n1 / n2
    ue1 = u ** (e - 1.0)
    ue2 = u ** (e - 2.0)
    dux = n2 * xa ** (n2 - 1.0) * sx / a
    duy = n2 * yb ** (n2 - 1.0) * sy / b
    duxx = n2 * (n2 - 1.0) * xa ** (n2 - 2.0) / (a * a)
    duyy = n2 * (n2 - 1.0) * yb ** (n2 - 2.0) / (b * b)
    gx = e * ue1 * dux
    gy = e * ue1 * duy
    gz = n1 * zc ** (n1 - 1.0) * sz / c
    hxx = e * (e - 1.0) * ue2 * dux * dux + e * ue1 * duxx
    hyy = e * (e - 1.0) * ue2 * duy * duy + e * ue1 * duyy
    hxy = e * (e - 1.0) * ue2 * dux * duy
    hzz = n1 * (n1 - 1.0) * zc ** (n1 - 2.0) / (c * c)
    g2 = gx * gx + gy * gy + gz * gz
    ghg = gx * gx * hxx + 2.0 * gx * gy * hxy + gy * gy * hyy + gz * gz * hzz
    twice_mean = (g2 * (hxx + hyy + hzz) - ghg) / (g2 * np.sqrt(g2))
    if not twice_mean * cap > 2.0:  # flatter than the cap (or not finite)
        return cap
    return 2.0 / twice_mean


def bounding_radius(a, b, c, n1, n2) -> float:
    """m: the largest distance of a surface point from the centre (the largest support value h(u) over unit u,
    sampled on 181 x 360 directions), plus 1 % for what the sampling misses (only the pre-check uses it)."""
    best = 0.0
    for theta in np.linspace(0.0, math.pi, 181):
        for phi in np.linspace(0.0, 2 * math.pi, 360, endpoint=False):
            u = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            p = support_point(a, b, c, n1, n2, *u)
            best = max(best, p[0] * u[0] + p[1] * u[1] + p[2] * u[2])
    return 1.01 * best


def smallest_curvature_radius(a, b, c, n1, n2) -> float:
    """m: the smallest mean-curvature radius over the surface (the support points of 91 x 180 directions; a
    corner's high curvature gathers many normal directions, so the sampling finds it)."""
    cap = radius_cap(a, b, c)
    best = cap
    for theta in np.linspace(0.0, math.pi, 91):
        for phi in np.linspace(0.0, 2 * math.pi, 180, endpoint=False):
            p = support_point(a, b, c, n1, n2, math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                              math.cos(theta))
            best = min(best, curvature_radius(a, b, c, n1, n2, p[0], p[1], p[2], cap))
    return best


def radius_cap(a, b, c) -> float:
    """m: the largest curvature radius a contact takes, max(a, b, c)^2 / min(a, b, c) (see the module
    docstring)."""
    return max(a, b, c) ** 2 / min(a, b, c)


# ---------------------------------------------------------------- compiled: contact geometry


@njit(cache=True, error_model="numpy", inline="always")
def _support_world(x, rot, shape, k, ux, uy, uz):
    """Support point of body k along u (space frame): (space point, body-frame point)."""
    bx = rot[k, 0, 0] * ux + rot[k, 1, 0] * uy + rot[k, 2, 0] * uz
    by = rot[k, 0, 1] * ux + rot[k, 1, 1] * uy + rot[k, 2, 1] * uz
    bz = rot[k, 0, 2] * ux + rot[k, 1, 2] * uy + rot[k, 2, 2] * uz
    px, py, pz = support_point(shape[k, 0], shape[k, 1], shape[k, 2], shape[k, 3], shape[k, 4], bx, by, bz)
    return (x[k, 0] + rot[k, 0, 0] * px + rot[k, 0, 1] * py + rot[k, 0, 2] * pz,
            x[k, 1] + rot[k, 1, 0] * px + rot[k, 1, 1] * py + rot[k, 1, 2] * pz,
            x[k, 2] + rot[k, 2, 0] * px + rot[k, 2, 1] * py + rot[k, 2, 2] * pz, px, py, pz)


@njit(cache=True, error_model="numpy")
def _along(x, rot, shape, i, j, nx, ny, nz):
    """Overlap d(n) = h_j(n) + h_i(-n) (m) along the unit normal n (from j to i) and its gradient w."""
    jx, jy, jz, _, _, _ = _support_world(x, rot, shape, j, nx, ny, nz)
    ix, iy, iz, _, _, _ = _support_world(x, rot, shape, i, -nx, -ny, -nz)
    wx = jx - ix
    wy = jy - iy
    wz = jz - iz
    return nx * wx + ny * wy + nz * wz, wx, wy, wz


@njit(cache=True, error_model="numpy", inline="always")
def _tangents(nx, ny, nz):
    """Two unit vectors that make an orthonormal basis with the unit n."""
    if abs(nx) < 0.6:
        ax, ay, az = 1.0, 0.0, 0.0
    else:
        ax, ay, az = 0.0, 1.0, 0.0
    e1x = ay * nz - az * ny
    e1y = az * nx - ax * nz
    e1z = ax * ny - ay * nx
    norm = np.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x /= norm
    e1y /= norm
    e1z /= norm
    return e1x, e1y, e1z, ny * e1z - nz * e1y, nz * e1x - nx * e1z, nx * e1y - ny * e1x


@njit(cache=True, error_model="numpy", inline="always")
def _unit(x, y, z):
    norm = np.sqrt(x * x + y * y + z * z)
    return x / norm, y / norm, z / norm


@njit(cache=True, error_model="numpy")
def pair_contact(x, rot, shape, i, j, nx, ny, nz, scale, start_on_axes):
    """The penetration depth of bodies i and j (m; < 0: apart) and its unit normal (from j to i), minimising
    d(n) = h_j(n) + h_i(-n) on the unit sphere from the start n (module docstring). scale (m): the sum of the
    bounding radii, for the tolerances. start_on_axes: start instead from whichever of n and the bodies'
    six axis directions (turned to n's side) gives the smallest d - for a new contact, whose line of centres
    may be far from the normal, most of all between blocky bodies, which often touch near a face normal.
    Returns (d, nx, ny, nz, iterations)."""
    nx, ny, nz = _unit(nx, ny, nz)
    d, wx, wy, wz = _along(x, rot, shape, i, j, nx, ny, nz)
    if start_on_axes:  # a new contact: the best of the start and the six half-axis directions near it
        for k in (i, j):
            for a in range(3):
                ax = rot[k, 0, a]
                ay = rot[k, 1, a]
                az = rot[k, 2, a]
                side = 1.0 if ax * nx + ay * ny + az * nz >= 0.0 else -1.0
                dm, vx, vy, vz = _along(x, rot, shape, i, j, side * ax, side * ay, side * az)
                if dm < d:
                    nx, ny, nz, d, wx, wy, wz = side * ax, side * ay, side * az, dm, vx, vy, vz
    it = 0
    while it < MAX_ITERATIONS and d > 0.0:
        it += 1
        e1x, e1y, e1z, e2x, e2y, e2z = _tangents(nx, ny, nz)
        g1 = e1x * wx + e1y * wy + e1z * wz
        g2 = e2x * wx + e2y * wy + e2z * wz
        if abs(g1) + abs(g2) <= GRADIENT_TOLERANCE * scale:
            break
        eps = DIFFERENCE_STEP
        ax, ay, az = _unit(nx + eps * e1x, ny + eps * e1y, nz + eps * e1z)
        _, w1x, w1y, w1z = _along(x, rot, shape, i, j, ax, ay, az)
        bx, by, bz = _unit(nx + eps * e2x, ny + eps * e2y, nz + eps * e2z)
        _, w2x, w2y, w2z = _along(x, rot, shape, i, j, bx, by, bz)
        h11 = (e1x * (w1x - wx) + e1y * (w1y - wy) + e1z * (w1z - wz)) / eps - d
        h22 = (e2x * (w2x - wx) + e2y * (w2y - wy) + e2z * (w2z - wz)) / eps - d
        h12 = 0.5 * ((e1x * (w2x - wx) + e1y * (w2y - wy) + e1z * (w2z - wz))
                     + (e2x * (w1x - wx) + e2y * (w1y - wy) + e2z * (w1z - wz))) / eps
        det = h11 * h22 - h12 * h12
        if h11 > 0.0 and det > 0.0:
            t1 = -(h22 * g1 - h12 * g2) / det
            t2 = -(h11 * g2 - h12 * g1) / det
        else:  # not convex here: a gradient step on the scale of the bodies
            t1 = -g1 / scale
            t2 = -g2 / scale
        size = np.sqrt(t1 * t1 + t2 * t2)
        if size > 0.5:
            t1 *= 0.5 / size
            t2 *= 0.5 / size
            size = 0.5
        accepted = False
        decrease = 0.0
        for _ in range(HALVINGS):
            mx, my, mz = _unit(nx + t1 * e1x + t2 * e2x, ny + t1 * e1y + t2 * e2y, nz + t1 * e1z + t2 * e2z)
            dm, vx, vy, vz = _along(x, rot, shape, i, j, mx, my, mz)
            if dm <= d:
                decrease = d - dm
                nx, ny, nz, d, wx, wy, wz = mx, my, mz, dm, vx, vy, vz
                accepted = True
                break
            t1 *= 0.5
            t2 *= 0.5
            size *= 0.5
        if not accepted or size < 1e-12 or decrease < DEPTH_TOLERANCE * d:
            break
    return d, nx, ny, nz, it


@njit(cache=True, error_model="numpy", inline="always")
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True, error_model="numpy")
def contact_force(laws, ti, tj, d, enx, eny, enz, vrx, vry, vrz, reff, meff, dt, char_vel, hist, slot):
    """Force on i (N) of a contact of overlap d (m) and unit normal en (from j to i), vr the velocity of i
    relative to j at the contact point (m/s): the normal law, then the tangential law (engine/contact_laws.py,
    as for spheres); hist[slot, 0:3] the shear displacement (history law)."""
    pp = laws.pp
    vn = vrx * enx + vry * eny + vrz * enz
    if laws.normal == 0:
        fn, _, kt, _, gt = hertz_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 1], pp[ti, tj, 2], reff, meff)
    else:
        fn, _, kt, _, gt = hooke_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 3], reff, meff, char_vel)
    if laws.limit_force:
        fn = max(fn, 0.0)
    if not laws.tangential_damping:
        gt = 0.0
    fx = fn * enx
    fy = fn * eny
    fz = fn * enz
    if laws.tangential != 0:
        vtx = vrx - vn * enx
        vty = vry - vn * eny
        vtz = vrz - vn * enz
        if laws.tangential == 1:
            ftx, fty, ftz = tangential_no_history(vtx, vty, vtz, gt, pp[ti, tj, 4], fn)
        else:
            ftx, fty, ftz, hist[slot, 0], hist[slot, 1], hist[slot, 2] = tangential_history(
                hist[slot, 0], hist[slot, 1], hist[slot, 2], vtx, vty, vtz, enx, eny, enz, kt, gt, pp[ti, tj, 4],
                fn, dt)
        fx += ftx
        fy += fty
        fz += ftz
    return fx, fy, fz


@njit(cache=True, error_model="numpy", inline="always")
def _point_velocity(sq, k, cx, cy, cz):
    """Velocity (m/s) of body k's material point at c: v + w x (c - x)."""
    rx = cx - sq.x[k, 0]
    ry = cy - sq.x[k, 1]
    rz = cz - sq.x[k, 2]
    tx, ty, tz = _cross(sq.omega[k, 0], sq.omega[k, 1], sq.omega[k, 2], rx, ry, rz)
    return sq.v[k, 0] + tx, sq.v[k, 1] + ty, sq.v[k, 2] + tz


@njit(cache=True, error_model="numpy", inline="always")
def _react(walls, w, fx, fy, fz, cx, cy, cz):
    """Wall w takes the opposite of the force F (N) a body feels at the point c (m), and its torque about the
    origin, -c x F (N m), as the walls of the sphere kernels do (engine/kernels.py)."""
    tx, ty, tz = _cross(cx, cy, cz, fx, fy, fz)
    walls.force[w, 0] -= fx
    walls.force[w, 1] -= fy
    walls.force[w, 2] -= fz
    walls.torque[w, 0] -= tx
    walls.torque[w, 1] -= ty
    walls.torque[w, 2] -= tz


@njit(cache=True, error_model="numpy", inline="always")
def _push(sq, k, sign, fx, fy, fz, cx, cy, cz):
    """sign F on body k at the point c: force and torque (c - x) x F."""
    sq.force[k, 0] += sign * fx
    sq.force[k, 1] += sign * fy
    sq.force[k, 2] += sign * fz
    tx, ty, tz = _cross(cx - sq.x[k, 0], cy - sq.x[k, 1], cz - sq.x[k, 2], fx, fy, fz)
    sq.torque[k, 0] += sign * tx
    sq.torque[k, 1] += sign * ty
    sq.torque[k, 2] += sign * tz


#: the cell grid of the pair search holds at most this many cells per body (a body far from the others makes
#: the cells larger rather than the grid huge)
CELLS_PER_BODY = 8


@njit(cache=True, error_model="numpy")
def _cell_grid(x, radius):
    """The bodies sorted into a grid of cubic cells of side at least twice the largest bounding radius, so
    that two bodies whose bounding spheres overlap lie in the same or neighbouring cells (the engine's cell
    list for spheres, engine/neighbor.py, in its plainest form; rebuilt every step, it costs O(N)). Returns
    (cell_start: the bodies of cell k are order[cell_start[k]:cell_start[k + 1]], in increasing index; order;
    cell_of: each body's cell; nc: cells per axis)."""
    nb = x.shape[0]
    nc = np.ones(3, dtype=np.int64)
    lo = np.zeros(3)
    side = 1.0
    if nb > 0:
        side = 2.0 * np.max(radius)
        for a in range(3):
            lo[a] = np.min(x[:, a])
        while True:
            total = 1
            for a in range(3):
                span = np.max(x[:, a]) - lo[a]
                # a non-finite position (a run blowing up) puts every body in one cell along that axis
                nc[a] = max(1, int(span / side) + 1) if span < 1e300 else 1
                total *= nc[a]
            if total <= CELLS_PER_BODY * nb + 27:
                break
            side *= 2.0
    cell_of = np.empty(nb, dtype=np.int64)
    cell_start = np.zeros(nc[0] * nc[1] * nc[2] + 1, dtype=np.int64)
    for i in range(nb):
        cx = max(0, min(int((x[i, 0] - lo[0]) / side), nc[0] - 1))
        cy = max(0, min(int((x[i, 1] - lo[1]) / side), nc[1] - 1))
        cz = max(0, min(int((x[i, 2] - lo[2]) / side), nc[2] - 1))
        cell_of[i] = (cx * nc[1] + cy) * nc[2] + cz
        cell_start[cell_of[i] + 1] += 1
    for k in range(len(cell_start) - 1):
        cell_start[k + 1] += cell_start[k]
    fill = cell_start[:-1].copy()
    order = np.empty(nb, dtype=np.int64)
    for i in range(nb):  # in increasing index within each cell
        order[fill[cell_of[i]]] = i
        fill[cell_of[i]] += 1
    return cell_start, order, cell_of, nc


@njit(cache=True, error_model="numpy")
def _neighbours(i, cell_start, order, cell_of, nc, near):
    """The bodies j > i in i's cell and the 26 around it, into near[:count] in increasing j (the order of the
    all-pairs loop, so that forces add up in the same order); returns count."""
    k = cell_of[i]
    cz = k % nc[2]
    cy = (k // nc[2]) % nc[1]
    cx = k // (nc[1] * nc[2])
    count = 0
    for ax in range(max(cx - 1, 0), min(cx + 2, nc[0])):
        for ay in range(max(cy - 1, 0), min(cy + 2, nc[1])):
            for az in range(max(cz - 1, 0), min(cz + 2, nc[2])):
                cell = (ax * nc[1] + ay) * nc[2] + az
                for h in range(cell_start[cell], cell_start[cell + 1]):
                    j = order[h]
                    if j > i:
                        near[count] = j
                        count += 1
    near[:count].sort()
    return count


@njit(cache=True, error_model="numpy")
def _pair_forces(sq, laws, dt, char_vel):
    x = sq.x
    rot = sq.rot
    shape = sq.shape
    nb = len(sq.mass)
    seen = np.zeros(SLOTS, dtype=np.bool_)
    cell_start, order, cell_of, nc = _cell_grid(x, sq.radius)
    near = np.empty(nb, dtype=np.int64)
    for i in range(nb):
        seen[:] = False
        count = _neighbours(i, cell_start, order, cell_of, nc, near)
        for c in range(count):
            j = near[c]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            reach = sq.radius[i] + sq.radius[j]
            rsq = dx * dx + dy * dy + dz * dz
            if rsq >= reach * reach:
                continue
            slot = -1
            for k in range(SLOTS):
                if sq.partner[i, k] == j:
                    slot = k
                    break
            if slot >= 0:
                nx, ny, nz = sq.hist[i, slot, 3], sq.hist[i, slot, 4], sq.hist[i, slot, 5]
            elif rsq > 0.0:
                nx, ny, nz = dx, dy, dz
            else:
                nx, ny, nz = 0.0, 0.0, 1.0
            d, enx, eny, enz, _ = pair_contact(x, rot, shape, i, j, nx, ny, nz, reach, slot < 0)
            if not d > 0.0:
                continue
            if slot < 0:
                for k in range(SLOTS):
                    if sq.partner[i, k] < 0:
                        slot = k
                        break
                if slot < 0:
                    sq.status[0] += 1
                    continue
                sq.partner[i, slot] = j
                for h in range(SLOT_WIDTH):
                    sq.hist[i, slot, h] = 0.0
            seen[slot] = True
            sq.hist[i, slot, 3] = enx
            sq.hist[i, slot, 4] = eny
            sq.hist[i, slot, 5] = enz
            jx, jy, jz, pjx, pjy, pjz = _support_world(x, rot, shape, j, enx, eny, enz)
            ix, iy, iz, pix, piy, piz = _support_world(x, rot, shape, i, -enx, -eny, -enz)
            cx = 0.5 * (ix + jx)
            cy = 0.5 * (iy + jy)
            cz = 0.5 * (iz + jz)
            ri = curvature_radius(shape[i, 0], shape[i, 1], shape[i, 2], shape[i, 3], shape[i, 4], pix, piy, piz,
                                  sq.rcap[i])
            rj = curvature_radius(shape[j, 0], shape[j, 1], shape[j, 2], shape[j, 3], shape[j, 4], pjx, pjy, pjz,
                                  sq.rcap[j])
            reff = ri * rj / (ri + rj)
            meff = sq.mass[i] * sq.mass[j] / (sq.mass[i] + sq.mass[j])
            vix, viy, viz = _point_velocity(sq, i, cx, cy, cz)
            vjx, vjy, vjz = _point_velocity(sq, j, cx, cy, cz)
            fx, fy, fz = contact_force(laws, sq.ptype[i], sq.ptype[j], d, enx, eny, enz, vix - vjx, viy - vjy,
                                       viz - vjz, reff, meff, dt, char_vel, sq.hist[i], slot)
            _push(sq, i, 1.0, fx, fy, fz, cx, cy, cz)
            _push(sq, j, -1.0, fx, fy, fz, cx, cy, cz)
        for k in range(SLOTS):  # contacts that opened: free the slot (history starts afresh, as for spheres)
            if not seen[k] and sq.partner[i, k] >= 0:
                sq.partner[i, k] = -1
                for h in range(SLOT_WIDTH):
                    sq.hist[i, k, h] = 0.0


@njit(cache=True, error_model="numpy")
def _plane_forces(sq, laws, walls, dt, char_vel, record):
    """Contacts with the planes: the support point along -en (en the plane's normal on the body's side) is
    the deepest point; overlap d its depth; contact point midway between it and the plane."""
    x = sq.x
    shape = sq.shape
    for i in range(len(sq.mass)):
        for w in range(walls.plane_point.shape[0]):
            nx = walls.plane_normal[w, 0]
            ny = walls.plane_normal[w, 1]
            nz = walls.plane_normal[w, 2]
            px0 = walls.plane_point[w, 0]
            py0 = walls.plane_point[w, 1]
            pz0 = walls.plane_point[w, 2]
            sep = (x[i, 0] - px0) * nx + (x[i, 1] - py0) * ny + (x[i, 2] - pz0) * nz
            hist = sq.wall_hist[i]
            if abs(sep) >= sq.radius[i]:
                hist[w, 0] = 0.0
                hist[w, 1] = 0.0
                hist[w, 2] = 0.0
                continue
            sign = 1.0 if sep >= 0.0 else -1.0
            enx = sign * nx
            eny = sign * ny
            enz = sign * nz
            sx, sy, sz, bx, by, bz = _support_world(x, sq.rot, shape, i, -enx, -eny, -enz)
            d = -((sx - px0) * enx + (sy - py0) * eny + (sz - pz0) * enz)
            cx = sx + 0.5 * d * enx
            cy = sy + 0.5 * d * eny
            cz = sz + 0.5 * d * enz
            if (not d > 0.0 or cx < walls.plane_lo[w, 0] or cx > walls.plane_hi[w, 0] or cy < walls.plane_lo[w, 1]
                    or cy > walls.plane_hi[w, 1] or cz < walls.plane_lo[w, 2] or cz > walls.plane_hi[w, 2]):
                hist[w, 0] = 0.0
                hist[w, 1] = 0.0
                hist[w, 2] = 0.0
                continue
            reff = curvature_radius(shape[i, 0], shape[i, 1], shape[i, 2], shape[i, 3], shape[i, 4], bx, by, bz,
                                    sq.rcap[i])
            vix, viy, viz = _point_velocity(sq, i, cx, cy, cz)
            fx, fy, fz = contact_force(laws, sq.ptype[i], walls.plane_type[w], d, enx, eny, enz,
                                       vix - walls.plane_vel[w, 0], viy - walls.plane_vel[w, 1],
                                       viz - walls.plane_vel[w, 2], reff, sq.mass[i], dt, char_vel, hist, w)
            _push(sq, i, 1.0, fx, fy, fz, cx, cy, cz)
            if record:
                _react(walls, w, fx, fy, fz, cx, cy, cz)


#: mesh triangles whose unit normals' dot product is at least 1 - FLAT (about 4.5e-5 rad apart) and whose corners
#: lie within FLAT_OFFSET of the bounding radius of each other's plane count as one plane for superquadric
#: contacts: an STL file keeps float32 corners, so the triangles of a turned flat face are coplanar only to
#: about 1e-7 rad - more than the 1e-12 of engine/mesh.py flat_parts, which decides for spheres (whose edge
#: contact equals the face contact there anyway)
FLAT = 1e-9
FLAT_OFFSET = 1e-6


@njit(cache=True, error_model="numpy", inline="always")
def _parallel(tn, t, u):
    return abs(tn[t, 0] * tn[u, 0] + tn[t, 1] * tn[u, 1] + tn[t, 2] * tn[u, 2]) >= 1.0 - FLAT


@njit(cache=True, error_model="numpy", inline="always")
def _coplanar(tv, tn, t, u, tol):
    """Triangles t and u lie in one plane (normals parallel to FLAT, u's corner within tol (m) of t's plane)."""
    off = ((tv[u, 0, 0] - tv[t, 0, 0]) * tn[t, 0] + (tv[u, 0, 1] - tv[t, 0, 1]) * tn[t, 1]
           + (tv[u, 0, 2] - tv[t, 0, 2]) * tn[t, 2])
    return _parallel(tn, t, u) and abs(off) <= tol


@njit(cache=True, error_model="numpy")
def _flat_part(walls, t, region):
    """Whether the edge or corner `region` of triangle t (engine/mesh.py closest_point) lies inside a flat part
    of its mesh, to FLAT: an edge shared with exactly one other triangle, parallel to t; a corner whose fan of
    triangles is closed (every neighbouring vertex is shared by two of them) and parallel to t."""
    vid = walls.tri_vid
    a = vid[t, region - 1] if region <= 3 else vid[t, region - 4]
    first = walls.fan_start[a]
    last = walls.fan_start[a + 1]
    if region <= 3:
        b = vid[t, region % 3]
        others = 0
        for k in range(first, last):
            u = walls.fan_tri[k]
            if u != t and (vid[u, 0] == b or vid[u, 1] == b or vid[u, 2] == b):
                others += 1
                if not _parallel(walls.tri_n, t, u):
                    return False
        return others == 1
    for k in range(first, last):
        u = walls.fan_tri[k]
        if not _parallel(walls.tri_n, t, u):
            return False
        for c in range(3):
            w = vid[u, c]
            if w == a:
                continue
            sharing = 0
            for h in range(first, last):
                f = walls.fan_tri[h]
                if vid[f, 0] == w or vid[f, 1] == w or vid[f, 2] == w:
                    sharing += 1
            if sharing != 2:
                return False
    return True


@njit(cache=True, error_model="numpy")
def _mesh_forces(sq, laws, walls, dt, char_vel, record):
    """Contacts with the triangles of mesh walls (engine/walls/mesh_wall.py), every triangle within a body's
    bounding sphere (docs/shapes.md, Superquadrics):

    - face: m the triangle's unit normal on the body's side, s = p(-m) the body's deepest point along it, d its
      depth below the triangle's plane; a contact of normal m and overlap d (as on a plane) when s projects
      into the triangle or onto its border (within FLAT_OFFSET of the bounding radius);
    - edge or corner, when it projects outside: q the triangle's point closest to that projection, the normal
      n = (x - q) / |x - q| (from q to the centre), the overlap d = h(-n) - |x - q| (h the body's support
      function: how far the body reaches past q along -n; r - |x - q| for a sphere). An edge or corner inside
      a flat part of the mesh (`_flat_part`, to FLAT) does not count: the coplanar neighbour holds the
      projection.

    One contact per body and plane of triangles: a contact whose normal equals (to FLAT) one already taken this step
    (a face on the shared edge of two coplanar triangles, an edge seen from both of its triangles) is the
    same contact. History (shear displacement) per slot, keyed by the triangle and carried to a coplanar
    triangle (a body sliding over a flat mesh keeps it). Contact point midway between the body's deepest
    point and the surface; R* the body's curvature radius there, the mesh's mass infinite."""
    x = sq.x
    shape = sq.shape
    tv = walls.tri_v
    tn = walls.tri_n
    ntri = tv.shape[0]
    seen = np.zeros(MESH_SLOTS, dtype=np.bool_)
    for i in range(len(sq.mass)):
        seen[:] = False
        r = sq.radius[i]
        xi0 = x[i, 0]
        xi1 = x[i, 1]
        xi2 = x[i, 2]
        for t in range(ntri):
            if (min(tv[t, 0, 0], tv[t, 1, 0], tv[t, 2, 0]) >= xi0 + r
                    or max(tv[t, 0, 0], tv[t, 1, 0], tv[t, 2, 0]) <= xi0 - r
                    or min(tv[t, 0, 1], tv[t, 1, 1], tv[t, 2, 1]) >= xi1 + r
                    or max(tv[t, 0, 1], tv[t, 1, 1], tv[t, 2, 1]) <= xi1 - r
                    or min(tv[t, 0, 2], tv[t, 1, 2], tv[t, 2, 2]) >= xi2 + r
                    or max(tv[t, 0, 2], tv[t, 1, 2], tv[t, 2, 2]) <= xi2 - r):
                continue
            qx, qy, qz, region = closest_point(xi0, xi1, xi2, tv, t)
            gx = xi0 - qx
            gy = xi1 - qy
            gz = xi2 - qz
            if gx * gx + gy * gy + gz * gz >= r * r:
                continue
            sep = (xi0 - tv[t, 0, 0]) * tn[t, 0] + (xi1 - tv[t, 0, 1]) * tn[t, 1] + (xi2 - tv[t, 0, 2]) * tn[t, 2]
            sign = 1.0 if sep >= 0.0 else -1.0
            mx = sign * tn[t, 0]
            my = sign * tn[t, 1]
            mz = sign * tn[t, 2]
            sx, sy, sz, bx, by, bz = _support_world(x, sq.rot, shape, i, -mx, -my, -mz)
            d = -((sx - tv[t, 0, 0]) * mx + (sy - tv[t, 0, 1]) * my + (sz - tv[t, 0, 2]) * mz)
            if not d > 0.0:  # the body does not reach the triangle's plane
                continue
            ox = sx + d * mx
            oy = sy + d * my
            oz = sz + d * mz
            qx, qy, qz, region = closest_point(ox, oy, oz, tv, t)
            # on the triangle's border (to round-off) is in it: a body over a shared edge or corner of a flat
            # part, whose projection each of its triangles puts on its border, takes the face contact (once)
            face = region == 0 or (ox - qx) ** 2 + (oy - qy) ** 2 + (oz - qz) ** 2 <= (FLAT_OFFSET * r) ** 2
            if face:
                enx = mx
                eny = my
                enz = mz
            else:
                if _flat_part(walls, t, region):
                    continue
                gx = xi0 - qx
                gy = xi1 - qy
                gz = xi2 - qz
                dist = np.sqrt(gx * gx + gy * gy + gz * gz)
                if dist == 0.0:
                    continue
                enx = gx / dist
                eny = gy / dist
                enz = gz / dist
                sx, sy, sz, bx, by, bz = _support_world(x, sq.rot, shape, i, -enx, -eny, -enz)
                d = (xi0 - sx) * enx + (xi1 - sy) * eny + (xi2 - sz) * enz - dist
                if not d > 0.0:
                    continue
            slot = -1
            duplicate = False
            for k in range(MESH_SLOTS):
                u = sq.mesh_tri[i, k]
                if u < 0 or u >= ntri:
                    continue
                same = u == t or (face and _coplanar(tv, tn, u, t, FLAT_OFFSET * r))
                if seen[k] and (same or sq.mesh_hist[i, k, 3] * enx + sq.mesh_hist[i, k, 4] * eny
                                + sq.mesh_hist[i, k, 5] * enz >= 1.0 - FLAT):
                    duplicate = True
                    break
                if same and slot < 0:
                    slot = k
            if duplicate:
                continue
            if slot < 0:
                for k in range(MESH_SLOTS):
                    if not seen[k] and (sq.mesh_tri[i, k] < 0 or sq.mesh_tri[i, k] >= ntri):
                        slot = k
                        break
                if slot < 0:
                    sq.status[0] += 1
                    continue
                for h in range(6):
                    sq.mesh_hist[i, slot, h] = 0.0
            sq.mesh_tri[i, slot] = t
            seen[slot] = True
            sq.mesh_hist[i, slot, 3] = enx
            sq.mesh_hist[i, slot, 4] = eny
            sq.mesh_hist[i, slot, 5] = enz
            cx = sx + 0.5 * d * enx
            cy = sy + 0.5 * d * eny
            cz = sz + 0.5 * d * enz
            mk = walls.tri_mesh[t]
            reff = curvature_radius(shape[i, 0], shape[i, 1], shape[i, 2], shape[i, 3], shape[i, 4], bx, by, bz,
                                    sq.rcap[i])
            vix, viy, viz = _point_velocity(sq, i, cx, cy, cz)
            px = cx - (walls.mesh_point0[mk, 0] + walls.mesh_shift[mk, 0])
            py = cy - (walls.mesh_point0[mk, 1] + walls.mesh_shift[mk, 1])
            pz = cz - (walls.mesh_point0[mk, 2] + walls.mesh_shift[mk, 2])
            om = walls.mesh_omega[mk]
            wx, wy, wz = _cross(om * walls.mesh_axis[mk, 0], om * walls.mesh_axis[mk, 1], om * walls.mesh_axis[mk, 2],
                                px, py, pz)
            fx, fy, fz = contact_force(laws, sq.ptype[i], walls.mesh_type[mk], d, enx, eny, enz,
                                       vix - walls.mesh_vel[mk, 0] - wx, viy - walls.mesh_vel[mk, 1] - wy,
                                       viz - walls.mesh_vel[mk, 2] - wz, reff, sq.mass[i], dt, char_vel,
                                       sq.mesh_hist[i], slot)
            _push(sq, i, 1.0, fx, fy, fz, cx, cy, cz)
            if record:
                _react(walls, walls.mesh_wall0[0] + mk, fx, fy, fz, cx, cy, cz)
        for k in range(MESH_SLOTS):  # contacts that opened: the slot is free, its history starts afresh
            if not seen[k] and sq.mesh_tri[i, k] >= 0:
                sq.mesh_tri[i, k] = -1
                for h in range(6):
                    sq.mesh_hist[i, k, h] = 0.0


@njit(cache=True, error_model="numpy")
def superquadric_pass(sq, laws, walls, gravity, dt, char_vel, collect, kick, drift, record):
    """The superquadrics' part of a step, in the order of the particle pass (engine/kernels.py INTEGRATE):
    with collect, the forces and torques at the current positions (gravity, pairs, planes); with kick, the
    second half kick (v += dt/2 F/m, L += dt/2 T); with drift, the next step's first half kick, the drift
    x += dt v and the rotation of q (clumps.advance_bodies). Angular velocity from L after it."""
    nb = len(sq.mass)
    if collect:
        for k in range(nb):
            clumps._rotation(sq.q[k, 0], sq.q[k, 1], sq.q[k, 2], sq.q[k, 3], sq.rot[k])
            for a in range(3):
                sq.force[k, a] = sq.mass[k] * gravity[a]
                sq.torque[k, a] = 0.0
        _pair_forces(sq, laws, dt, char_vel)
        _plane_forces(sq, laws, walls, dt, char_vel, record)
        _mesh_forces(sq, laws, walls, dt, char_vel, record)
    clumps.advance_bodies(sq.x, sq.v, sq.angmom, sq.q, sq.inertia, sq.omega, sq.force, sq.torque, sq.mass,
                          np.ones(nb, dtype=np.int64), dt, kick, drift)  # every body is present


# ---------------------------------------------------------------- kernel hooks (engine/kernels.py STEP_LOOP)

#: the trailing arguments of setup and run_steps in a scene with superquadrics
ARGUMENTS = ", sq, sq_laws"
SETUP = "superquadric_pass(sq, sq_laws, walls, gravity, dt, char_vel, True, False, False, record)\n"
START = "superquadric_pass(sq, sq_laws, walls, gravity, dt, char_vel, off, off, on, off)\n"
STEP = "superquadric_pass(sq, sq_laws, walls, gravity, dt, char_vel, on, on, not record, record)\n"


# ---------------------------------------------------------------- Python side


class Shape:
    """A superquadric's shape and material: half-axes (m), blockiness, and what follows from them."""

    def __init__(self, ptype: int, half_axes, blockiness, density: float):
        self.type = ptype
        self.a, self.b, self.c = (float(v) for v in half_axes)
        self.n1, self.n2 = (float(v) for v in blockiness)
        props = mass_properties(self.a, self.b, self.c, self.n1, self.n2, density)
        self.mass = props["mass"]
        self.volume = props["volume"]
        self.moments = props["moments"]
        self.radius = bounding_radius(self.a, self.b, self.c, self.n1, self.n2)
        self.rcap = radius_cap(self.a, self.b, self.c)

    @property
    def row(self):
        return [self.a, self.b, self.c, self.n1, self.n2]


def planes(sim) -> int:
    return sum(1 for w in sim.walls if w["shape"] == "plane")


def add(sim, shape: Shape, positions, quaternions, velocity, omega):
    """Superquadrics of one shape at positions (m, k x 3) with orientations (body -> space, k x 4), one velocity
    (m/s) and angular velocity (rad/s, space frame)."""
    positions = np.asarray(positions, float).reshape(-1, 3)
    k = len(positions)
    if k == 0:
        return
    sq = sim.superquadrics if sim.superquadrics is not None else empty(planes(sim))
    q = np.asarray(quaternions, float).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1)[:, None]
    rot = clumps.rotation_matrices(q)
    omega = np.asarray(omega, float)
    inertia = np.tile(shape.moments, (k, 1))
    angmom = np.einsum("kab,kb->ka", rot, inertia * np.einsum("kba,b->ka", rot, omega))  # L = R I R^T w
    first = len(sq.mass)
    mass = np.full(k, shape.mass)
    sim.superquadrics = sq._replace(
        x=np.concatenate([sq.x, positions]), v=np.concatenate([sq.v, np.tile(np.asarray(velocity, float), (k, 1))]),
        q=np.concatenate([sq.q, q]), angmom=np.concatenate([sq.angmom, angmom]),
        omega=np.concatenate([sq.omega, np.tile(omega, (k, 1))]), inertia=np.concatenate([sq.inertia, inertia]),
        mass=np.concatenate([sq.mass, mass]), shape=np.concatenate([sq.shape, np.tile(shape.row, (k, 1))]),
        radius=np.concatenate([sq.radius, np.full(k, shape.radius)]),
        rcap=np.concatenate([sq.rcap, np.full(k, shape.rcap)]),
        ptype=np.concatenate([sq.ptype, np.full(k, shape.type - 1, dtype=np.int64)]),
        sid=np.concatenate([sq.sid, np.arange(first + 1, first + k + 1, dtype=np.int64)]),
        force=np.concatenate([sq.force, mass[:, None] * sim.gravity_vector()[None, :]]),
        torque=np.concatenate([sq.torque, np.zeros((k, 3))]),
        partner=np.concatenate([sq.partner, np.full((k, SLOTS), -1, dtype=np.int64)]),
        hist=np.concatenate([sq.hist, np.zeros((k, SLOTS, SLOT_WIDTH))]),
        wall_hist=np.concatenate([sq.wall_hist, np.zeros((k,) + sq.wall_hist.shape[1:])]),
        mesh_tri=np.concatenate([sq.mesh_tri, np.full((k, MESH_SLOTS), -1, dtype=np.int64)]),
        mesh_hist=np.concatenate([sq.mesh_hist, np.zeros((k, MESH_SLOTS, 6))]),
        rot=np.zeros((first + k, 3, 3)))
    sim.dirty = True


def fit_walls(sim):
    """The wall history as wide as the scene's planes (a changed wall list starts it afresh)."""
    sq = sim.superquadrics
    want = (len(sq.mass), planes(sim), 3)
    if sq.wall_hist.shape != want:
        sim.superquadrics = sq._replace(wall_hist=np.zeros(want))


def laws(sim) -> Laws:
    """The contact model for superquadric contacts, or ValueError naming what they cannot do."""
    model = sim.model
    for kind in ("cohesion", "rolling"):
        if model.get(kind, "none") != "none":
            raise ValueError(f"the {kind} submodel '{model[kind]}' is not implemented for superquadrics "
                             "(normal and tangential only)")
    ntypes = max(sim.materials)
    pp = np.full((ntypes, ntypes, len(LAW_COLUMNS)), np.nan)
    for a in range(1, ntypes + 1):
        for b in range(1, ntypes + 1):
            inter = sim.interactions.get((min(a, b), max(a, b)))
            if a not in sim.materials or b not in sim.materials or inter is None:
                continue
            for k, name in enumerate(LAW_COLUMNS):
                pp[a - 1, b - 1, k] = PARAMETERS[name].value(sim.materials[a], sim.materials[b], inter)
    return Laws(pp, NORMAL_LAWS[model["normal"]], TANGENTIAL_LAWS[model["tangential"]],
                bool(model.get("limit_force", False)), bool(model.get("tangential_damping", True)))


def problem(sim) -> str | None:
    """Why this scene's superquadrics cannot run (walls or particles they cannot touch), or None."""
    if sim.superquadrics is None or not len(sim.superquadrics.mass):
        return None
    others = sorted({w["shape"] for w in sim.walls} - {"plane", "mesh"})
    if others:
        return (f"superquadrics touch planes and meshes only, not {' or '.join(others)} walls "
                f"(walls: {', '.join(w['name'] for w in sim.walls)})")
    if sim.n or sim.bodies is not None or any(mod.kind == "insert" for mod in sim.active_modifiers()):
        return "superquadrics do not touch spheres or clumps: a scene has one or the other (no insert modifier)"
    if np.any(sim.periodic):
        return "superquadrics need a domain without periodic axes"
    try:
        laws(sim)
    except ValueError as exc:
        return str(exc)
    return None


def count(sim) -> int:
    return 0 if sim.superquadrics is None else len(sim.superquadrics.mass)


# ---------------------------------------------------------------- quantities


def kinetic_energy(sim) -> float:
    sq = sim.superquadrics
    return float(0.5 * np.sum(sq.mass * np.einsum("ij,ij->i", sq.v, sq.v)))


def rotational_energy(sim) -> float:
    """J: 1/2 L.w."""
    sq = sim.superquadrics
    return float(0.5 * np.sum(np.einsum("ij,ij->i", sq.angmom, sq.omega)))


#: per superquadric: sq_NAME[ID] with ID its id (from 1, in creation order); w1..w3 the angular velocity in
#: the body frame (about the half-axes a, b, c)
QUANTITIES = dict(clumps.BODY_QUANTITIES)


def value(sim, name: str, sid: int) -> float:
    sq = sim.superquadrics
    if sq is None or not 1 <= sid <= len(sq.mass):
        return math.nan
    k = sid - 1
    field, component = QUANTITIES[name]
    if field == "body_omega":
        rot = clumps.rotation_matrices(sq.q[k:k + 1])[0]
        return float((rot.T @ sq.omega[k])[component])
    return float(getattr(sq, field)[k, component])


def critical_times(sim) -> tuple:
    """(Rayleigh time, Hertz time) in s of a scene's superquadrics: the formulas of engine/guards.py
    (critical_timestep) with r the smallest mean-curvature radius of each shape (`smallest_curvature_radius`;
    a sphere's radius for a = b = c, n = 2), m the body's mass, Y* the largest over the types it can touch,
    v = max(2 v_max, v_max + v_wall). The curvature radius takes the place of the sphere's radius in the
    Hertz contact, and the smaller it is, the shorter the Rayleigh time and the stiffer the contact per unit
    of mass."""
    sq = sim.superquadrics
    if sq is None or not len(sq.mass):
        return math.inf, math.inf
    radii = np.array([_smallest_radius(tuple(row)) for row in sq.shape])
    user = sq.ptype + 1
    y, nu, rho = (np.array([sim.materials[t][k] for t in user]) for k in range(3))
    shear = y / (2.0 * (1.0 + nu))
    t_r = float(np.min(math.pi * radii * np.sqrt(rho / shear) / (0.1631 * nu + 0.8766)))
    v_max = float(np.sqrt(np.max(np.einsum("ij,ij->i", sq.v, sq.v))))
    v = max(2.0 * v_max, v_max + max(surface_speeds(sim), default=0.0))
    if v == 0.0:
        return t_r, math.inf
    partners = set(user.tolist()) | {w["type"] for w in sim.walls}
    ystar = np.array([max(effective_youngs_modulus(*sim.materials[t][:2], *sim.materials[p][:2]) for p in partners)
                      for t in user])
    t_h = float(np.min(2.87 * (sq.mass * sq.mass / (0.5 * radii * ystar * ystar * v)) ** 0.2))
    return t_r, t_h


_RADII: dict = {}


def _smallest_radius(row) -> float:
    if row not in _RADII:
        _RADII[row] = smallest_curvature_radius(*row)
    return _RADII[row]


# ---------------------------------------------------------------- restart files

RESTART_ARRAYS = {f"sq_{name}": name for name in Superquadrics._fields if name not in ("rot", "status")}


def restart_arrays(sim) -> dict:
    if sim.superquadrics is None:
        return {}
    return {key: getattr(sim.superquadrics, name) for key, name in RESTART_ARRAYS.items()}


def restore(sim, data: dict):
    """The superquadrics of a restart file (none when it holds none), checked."""
    if "sq_mass" not in data:
        sim.superquadrics = None
        return
    nb = len(data["sq_mass"])
    # files written before superquadrics touched meshes hold no mesh contacts: none open
    defaults = {"sq_mesh_tri": np.full((nb, MESH_SLOTS), -1, dtype=np.int64),
                "sq_mesh_hist": np.zeros((nb, MESH_SLOTS, 6))}
    missing = [key for key in RESTART_ARRAYS if key not in data and key not in defaults]
    if missing:
        raise ValueError(f"the superquadric arrays {', '.join(missing)} are missing")
    arrays = {name: np.ascontiguousarray(data[key] if key in data else defaults[key])
              for key, name in RESTART_ARRAYS.items()}
    shapes = dict(x=(nb, 3), v=(nb, 3), q=(nb, 4), angmom=(nb, 3), omega=(nb, 3), inertia=(nb, 3), mass=(nb,),
                  shape=(nb, 5), radius=(nb,), rcap=(nb,), ptype=(nb,), sid=(nb,), force=(nb, 3), torque=(nb, 3),
                  partner=(nb, SLOTS), hist=(nb, SLOTS, SLOT_WIDTH), mesh_tri=(nb, MESH_SLOTS),
                  mesh_hist=(nb, MESH_SLOTS, 6))
    for name, shape in shapes.items():
        if arrays[name].shape != shape or not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"array 'sq_{name}' has shape {arrays[name].shape}, expected {shape}, or "
                             "non-finite values")
    if (arrays["wall_hist"].ndim != 3 or arrays["wall_hist"].shape[0] != nb or np.any(arrays["mass"] <= 0)
            or np.any(arrays["inertia"] <= 0) or np.any(arrays["shape"][:, :3] <= 0)
            or np.any(arrays["shape"][:, 3:] < 2) or np.any(arrays["partner"] >= nb)
            or np.any(arrays["mesh_tri"] < -1) or np.any(arrays["ptype"] < 0)):
        raise ValueError("the superquadric arrays are out of range")
    for name in ("ptype", "sid", "partner", "mesh_tri"):
        arrays[name] = arrays[name].astype(np.int64)
    sim.superquadrics = Superquadrics(rot=np.zeros((nb, 3, 3)), status=np.zeros(1, dtype=np.int64), **arrays)


# ---------------------------------------------------------------- VTK output


def write_vtk(sim, folder, prefix: str):
    """post/<prefix>_superquadrics_<step>.vtp: a point per body with its id, type, velocity, omega, orientation
    (quaternion w, x, y, z, and the rotation matrix as a 9-component tensor, row-major: ParaView's Tensor Glyph
    filter draws a superellipsoid with it), half-axes and blockiness."""
    from .writers import write_vtp
    sq = sim.superquadrics
    rot = clumps.rotation_matrices(sq.q) if len(sq.mass) else np.zeros((0, 3, 3))
    scaled = rot * sq.shape[:, None, :3]  # columns: the half-axes in space
    write_vtp(folder / f"{prefix}_superquadrics_{sim.step}.vtp", sq.sid, sq.ptype + 1, sq.x, sq.v, sq.force,
              sq.omega, sq.radius, extra={"quaternion": sq.q, "half_axes": sq.shape[:, :3],
                                          "blockiness": sq.shape[:, 3:], "axes": scaled.reshape(-1, 9)})
