"""Multisphere clumps: rigid bodies made of (possibly overlapping) spheres.

A clump template (`create clump_template`) is a list of spheres in its own frame and a material type. Its
mass, centre of mass and inertia tensor are integrated over the union of the spheres, so that overlaps count
once (`mass_properties`); its body frame is the frame of the principal axes.

Inside the engine a clump is its member spheres - ordinary particles of the state, so that contact detection,
every wall shape, VTK dumps and restart files treat them as they treat any sphere - plus one row of `Bodies`
(centre of mass, velocity, orientation quaternion, angular momentum). What makes the members a rigid body,
and is compiled only into the kernels of scenes that have clumps (`engine.kernels`, `Combination.clumps`):

- a member's `inv_mass` and `inv_inertia` are 0, so the particle pass's half kicks leave it alone; its `mass`
  is its body's mass (the effective mass of a contact is the body's, as in LIGGGHTS' multisphere model);
- pairs of two members of one body are skipped in the pair loop (`SAME_BODY`);
- on one thread the particle pass stores a member's force and torque totals where it starts a free sphere's
  next evaluation (m g, zero) after the drift (`member_clear`): body_pass reads and clears them;
- after each force evaluation `body_pass` sums the members' forces (without their gravity, m_body g each)
  onto the body, and their torques plus (x_i - X) x F_i; then integrates the body (velocity Verlet for the
  translation and the angular momentum, Richardson iteration for the quaternion) and places the members
  (x_i = X + R(q) b_i, v_i = V + w x (x_i - X), w_i = w).

Member sphere -> body is an array indexed by particle id (`member_body`, `member_offset`: the member's centre in
the body frame), since neighbor rebuilds re-order the particles but never change their ids.
"""
from __future__ import annotations

import json
import math
from collections import namedtuple

import numpy as np

from . import particle_set
from . import state as particle_state
from .jit import njit
from .neighbor import tally_overlap

#: per body (rows) and per particle id (member_body, member_offset); passed whole to compiled code
Bodies = namedtuple("Bodies", ["x", "v", "q", "angmom", "omega", "inertia", "mass", "force", "torque", "members",
                               "bid", "rot", "member_body", "member_offset"])
Bodies.__doc__ = ("Rigid bodies: centre of mass x (m), velocity v (m/s), orientation quaternion q (w, x, y, z; "
                  "body frame -> space), angular momentum (kg m^2/s, space frame), angular velocity omega "
                  "(rad/s, space frame), principal moments inertia (kg m^2), mass (kg), force (N) and torque "
                  "(N m) of the last force evaluation, members present, body id (from 1), work space for the rotation "
                  "matrices; per particle id the "
                  "body index (-1: a free sphere) and the member's centre in the body frame (m).")

#: quasi-random points (engine.clumps.halton_points) for the mass properties of a template whose spheres overlap
DEFAULT_SAMPLES = 2 ** 20


def empty_bodies(ids: int = 1) -> Bodies:
    return Bodies(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4)), np.zeros((0, 3)), np.zeros((0, 3)),
                  np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64),
                  np.zeros(0, dtype=np.int64), np.zeros((0, 3, 3)), np.full(ids, -1, dtype=np.int64),
                  np.zeros((ids, 3)))


# ---------------------------------------------------------------- mass properties


def mass_properties(centres, radii, density: float, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> dict:
    """Volume (m^3), mass (kg), centre of mass (m), inertia tensor about it (kg m^2) of a union of spheres.

    Spheres that do not overlap: exact (sum of 4/3 pi r^3 and 2/5 m r^2, parallel-axis theorem). Overlapping
    spheres: integration over quasi-random points in the bounding box (`halton_points`), each point counted
    once however many spheres hold it (LIGGGHTS' fix particletemplate/multisphere integrates by Monte Carlo
    too). `error` is the relative standard error of plain Monte Carlo with as many points,
    sqrt((1 - p) / (p N)) for the volume fraction p of the box - an upper bound for the quasi-random points
    (whose error falls about as 1/N); the centre of mass and the inertia have errors of the same order relative
    to the clump's size.
    """
    c = np.asarray(centres, dtype=float).reshape(-1, 3)
    r = np.asarray(radii, dtype=float).reshape(-1)
    gap = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2) - (r[:, None] + r[None, :])
    np.fill_diagonal(gap, np.inf)
    if np.all(gap >= 0.0):
        vol = 4.0 / 3.0 * math.pi * r ** 3
        m = density * vol
        com = (m[:, None] * c).sum(axis=0) / m.sum()
        d = c - com
        inertia = np.zeros((3, 3))
        for k in range(len(r)):
            inertia += 0.4 * m[k] * r[k] ** 2 * np.eye(3) + m[k] * (d[k] @ d[k] * np.eye(3) - np.outer(d[k], d[k]))
        return dict(volume=float(vol.sum()), mass=float(m.sum()), com=com, inertia=inertia, error=0.0, exact=True)
    lo = (c - r[:, None]).min(axis=0)
    hi = (c + r[:, None]).max(axis=0)
    box = float(np.prod(hi - lo))
    count = 0
    first = np.zeros(3)
    second = np.zeros((3, 3))
    n_total = 0
    remaining = int(samples)
    while remaining > 0:  # in batches: 2^16 points x spheres of booleans at a time
        take = min(remaining, 2 ** 16)
        p = lo + (hi - lo) * halton_points(n_total, take, seed)
        inside = np.zeros(take, dtype=bool)
        for k in range(len(r)):
            inside |= np.einsum("ij,ij->i", p - c[k], p - c[k]) <= r[k] * r[k]
        q = p[inside]
        count += len(q)
        first += q.sum(axis=0)
        second += q.T @ q
        n_total += take
        remaining -= take
    frac = count / n_total
    volume = box * frac
    mass = density * volume
    com = first / count
    cov = second / count - np.outer(com, com)  # second moments about the centre of mass, per unit mass
    inertia = mass * (np.trace(cov) * np.eye(3) - cov)
    error = math.sqrt((1.0 - frac) / (frac * n_total))
    return dict(volume=volume, mass=mass, com=com, inertia=inertia, error=error, exact=False)


def halton_points(start: int, count: int, seed: int) -> np.ndarray:
    """Points start .. start + count - 1 of the 3-d Halton sequence (radical inverses in bases 2, 3, 5) in the
    unit cube, shifted modulo 1 by one random vector drawn from seed (Cranley-Patterson rotation: the points
    keep their low discrepancy - error about (log N)^3 / N - and become an unbiased estimate)."""
    shift = np.random.Generator(np.random.PCG64([seed, 7])).random(3)
    out = np.empty((count, 3))
    for axis, base in enumerate((2, 3, 5)):
        index = np.arange(start + 1, start + count + 1, dtype=np.int64)
        value = np.zeros(count)
        scale = 1.0
        while np.any(index > 0):
            scale /= base
            value += scale * (index % base)
            index //= base
        out[:, axis] = (value + shift[axis]) % 1.0
    return out


def principal_frame(inertia: np.ndarray):
    """(principal moments ascending, rotation A whose columns are the axes, det A = +1)."""
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def quaternion_of_matrix(a: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method: the largest of the four squares
    first, for accuracy)."""
    t = np.trace(a)
    squares = [1 + t, 1 + 2 * a[0, 0] - t, 1 + 2 * a[1, 1] - t, 1 + 2 * a[2, 2] - t]
    k = int(np.argmax(squares))
    s = math.sqrt(squares[k]) * 2.0
    if k == 0:
        q = [0.25 * s, (a[2, 1] - a[1, 2]) / s, (a[0, 2] - a[2, 0]) / s, (a[1, 0] - a[0, 1]) / s]
    elif k == 1:
        q = [(a[2, 1] - a[1, 2]) / s, 0.25 * s, (a[0, 1] + a[1, 0]) / s, (a[0, 2] + a[2, 0]) / s]
    elif k == 2:
        q = [(a[0, 2] - a[2, 0]) / s, (a[0, 1] + a[1, 0]) / s, 0.25 * s, (a[1, 2] + a[2, 1]) / s]
    else:
        q = [(a[1, 0] - a[0, 1]) / s, (a[0, 2] + a[2, 0]) / s, (a[1, 2] + a[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)


def quaternion_product(p, q) -> np.ndarray:
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return np.array([pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw])


def axis_angle_quaternion(axis, angle_deg: float) -> np.ndarray:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    h = 0.5 * math.radians(angle_deg)
    return np.array([math.cos(h), *(math.sin(h) * a)])


def random_quaternions(rng: np.random.Generator, count: int) -> np.ndarray:
    """Uniformly distributed orientations (Shoemake's subgroup algorithm, Graphics Gems III)."""
    u1, u2, u3 = rng.random((3, count))
    a, b = np.sqrt(1 - u1), np.sqrt(u1)
    return np.stack([b * np.cos(2 * np.pi * u3), a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2),
                     b * np.sin(2 * np.pi * u3)], axis=1)


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotation matrices (body -> space) of unit quaternions (n, 4)."""
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


class Template:
    """A clump template: spheres in the template frame, material type, and its mass properties."""

    def __init__(self, name: str, ptype: int, centres, radii, density: float, samples: int, seed: int):
        self.name = name
        self.type = ptype
        self.centres = np.asarray(centres, float)
        self.radii = np.asarray(radii, float)
        props = mass_properties(self.centres, self.radii, density, samples, seed)
        self.mass = props["mass"]
        self.volume = props["volume"]
        self.error = props["error"]
        self.exact = props["exact"]
        self.com = props["com"]
        self.moments, self.axes = principal_frame(props["inertia"])
        #: member centres in the body (principal) frame, m
        self.offsets = (self.centres - self.com) @ self.axes
        #: the frame of the principal axes relative to the template frame
        self.q_axes = quaternion_of_matrix(self.axes)
        #: radius of the sphere about the centre of mass that holds every member (insertion, packing)
        self.bounding_radius = float(np.max(np.linalg.norm(self.offsets, axis=1) + self.radii))

    def definition(self) -> dict:
        return dict(name=self.name, type=self.type, centres=self.centres.tolist(), radii=self.radii.tolist())


# ---------------------------------------------------------------- compiled: integration


@njit(cache=True, error_model="numpy")
def _rotation(q0, q1, q2, q3, rot):
    rot[0, 0] = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    rot[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    rot[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    rot[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    rot[1, 1] = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    rot[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    rot[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    rot[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    rot[2, 2] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)


@njit(cache=True, error_model="numpy", inline="always")
def _omega(q0, q1, q2, q3, l0, l1, l2, i0, i1, i2):
    """w = R diag(1/I) R^T L (rad/s, space frame) of the orientation quaternion (q0, q1, q2, q3), angular
    momentum L (kg m^2/s, space frame) and principal moments I (kg m^2): scalars in, scalars out."""
    ax0 = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    ax1 = 2.0 * (q1 * q2 + q0 * q3)
    ax2 = 2.0 * (q1 * q3 - q0 * q2)
    ay0 = 2.0 * (q1 * q2 - q0 * q3)
    ay1 = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    ay2 = 2.0 * (q2 * q3 + q0 * q1)
    az0 = 2.0 * (q1 * q3 + q0 * q2)
    az1 = 2.0 * (q2 * q3 - q0 * q1)
    az2 = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    wb0 = (ax0 * l0 + ax1 * l1 + ax2 * l2) / i0
    wb1 = (ay0 * l0 + ay1 * l1 + ay2 * l2) / i1
    wb2 = (az0 * l0 + az1 * l1 + az2 * l2) / i2
    return (ax0 * wb0 + ay0 * wb1 + az0 * wb2, ax1 * wb0 + ay1 * wb1 + az1 * wb2,
            ax2 * wb0 + ay2 * wb1 + az2 * wb2)


@njit(cache=True, error_model="numpy", inline="always")
def _quaternion_step(q0, q1, q2, q3, w0, w1, w2, h):
    """Normalised q + h dq/dt with dq/dt = 1/2 (0, w) q (w in the space frame)."""
    n0 = q0 - h * 0.5 * (w0 * q1 + w1 * q2 + w2 * q3)
    n1 = q1 + h * 0.5 * (w0 * q0 + w1 * q3 - w2 * q2)
    n2 = q2 + h * 0.5 * (w1 * q0 + w2 * q1 - w0 * q3)
    n3 = q3 + h * 0.5 * (w2 * q0 + w0 * q2 - w1 * q1)
    norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    return n0 / norm, n1 / norm, n2 / norm, n3 / norm


@njit(cache=True, error_model="numpy", inline="always")
def rotate(q0, q1, q2, q3, l0, l1, l2, i0, i1, i2, dt):
    """The orientation quaternion q advanced by one time step dt (s) with the angular momentum L of the half
    step (kg m^2/s, space frame) and principal moments I (kg m^2): scalars in, the new q out.

    Richardson extrapolation of the first-order update of dq/dt = 1/2 (0, w) q, w = R(q) I^-1 R(q)^T L:
    one full step q_1 and two half steps q_1/2 (w recomputed at the midpoint), then q = 2 q_1/2 - q_1,
    normalised: second order in dt. The scheme of LAMMPS' fix rigid and LIGGGHTS' fix multisphere
    (Kamberaj, Low and Neal, J. Chem. Phys. 122 (2005) 224114, for the splitting of translation and rotation;
    the Richardson step as in LAMMPS' MathExtra::richardson). Angular momentum is kept in the space frame, so
    that without torque it is conserved exactly.
    """
    w0, w1, w2 = _omega(q0, q1, q2, q3, l0, l1, l2, i0, i1, i2)
    f0, f1, f2, f3 = _quaternion_step(q0, q1, q2, q3, w0, w1, w2, dt)
    h0, h1, h2, h3 = _quaternion_step(q0, q1, q2, q3, w0, w1, w2, 0.5 * dt)
    w0, w1, w2 = _omega(h0, h1, h2, h3, l0, l1, l2, i0, i1, i2)
    s0, s1, s2, s3 = _quaternion_step(h0, h1, h2, h3, w0, w1, w2, 0.5 * dt)
    r0 = 2.0 * s0 - f0
    r1 = 2.0 * s1 - f1
    r2 = 2.0 * s2 - f2
    r3 = 2.0 * s3 - f3
    norm = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
    return r0 / norm, r1 / norm, r2 / norm, r3 / norm


#: bodies per sweep of advance_bodies, the length of its columns: a literal, so that the columns lie a
#: constant distance apart and LLVM turns the sweeps over them into SIMD instructions (as the pair loop's
#: CONTACT_CHUNK, engine/kernels.py); 16 doubles per body: 8 kB, in L1
BODY_CHUNK = 64


@njit(cache=True, error_model="numpy")
def advance_bodies(x, v, angmom, q, inertia, omega, force, torque, mass, present, dt, kick, drift):
    """The rigid bodies' share of the velocity Verlet step (engine/kernels.py INTEGRATE), in place, for every
    body k with present[k] != 0 (the others stay as they are): with kick, the second half kick of the step
    (v += dt/2 F/m in m/s, L += dt/2 T in kg m^2/s); with drift, the next step's first half kick, the drift
    x += dt v (m) and the rotation of q (`rotate`). Then the angular velocity w = R I^-1 R^T L (rad/s). The
    one home of the rule for clumps and superquadrics.

    The bodies are taken BODY_CHUNK at a time in three sweeps: (1) the kicks and the drift of x, body by body,
    gathering q, L and I into columns; (2) the rotation and the angular velocity of every gathered body, a
    loop without loads from the bodies' arrays, which LLVM turns into SIMD instructions (square roots and
    divisions round as the scalar ones do: the same bytes); (3) q and w written back. A body's arithmetic is
    the same, in the same order, as body by body (bodies do not interact here): only the schedule changes.
    (A call per body cost more than its arithmetic: about 180 ns per body, against 40 ns in sweeps.)"""
    nb = mass.shape[0]
    col = np.empty((13, BODY_CHUNK))
    which = np.empty(BODY_CHUNK, dtype=np.int64)
    half_dt = 0.5 * dt
    k = 0
    while k < nb:
        m = 0
        while m < BODY_CHUNK and k < nb:
            if present[k] != 0:
                inv_m = 1.0 / mass[k]
                if kick:
                    for a in range(3):
                        v[k, a] += half_dt * force[k, a] * inv_m
                        angmom[k, a] += half_dt * torque[k, a]
                if drift:
                    for a in range(3):
                        v[k, a] += half_dt * force[k, a] * inv_m
                        angmom[k, a] += half_dt * torque[k, a]
                        x[k, a] += dt * v[k, a]
                which[m] = k
                for a in range(4):
                    col[a, m] = q[k, a]
                for a in range(3):
                    col[4 + a, m] = angmom[k, a]
                    col[7 + a, m] = inertia[k, a]
                m += 1
            k += 1
        if drift:
            for c in range(m):
                q0, q1, q2, q3 = rotate(col[0, c], col[1, c], col[2, c], col[3, c], col[4, c], col[5, c],
                                        col[6, c], col[7, c], col[8, c], col[9, c], dt)
                col[0, c] = q0
                col[1, c] = q1
                col[2, c] = q2
                col[3, c] = q3
        for c in range(m):
            w0, w1, w2 = _omega(col[0, c], col[1, c], col[2, c], col[3, c], col[4, c], col[5, c], col[6, c],
                                col[7, c], col[8, c], col[9, c])
            col[10, c] = w0
            col[11, c] = w1
            col[12, c] = w2
        for c in range(m):
            kc = which[c]
            for a in range(4):
                q[kc, a] = col[a, c]
            for a in range(3):
                omega[kc, a] = col[10 + a, c]


@njit(cache=True, error_model="numpy")
def body_pass(s, n, b, gravity, dt, collect, kick, drift, half_skin_sq, lo, hi, periodic):
    """The bodies' part of a step (see the module docstring); the particle pass has done the free spheres.

    collect: sum the members' forces and torques onto their bodies (and clear the members' for the next force
    evaluation: m g and zero); kick: the second half kick of V and L; drift: the next step's first half kick,
    the drift of X and the rotation of q. Then every member is placed (drift) and given its body's velocity
    at its centre and the body's angular velocity. Returns (members beyond skin/2 since the last rebuild,
    first member with a non-finite position or n), as the particle pass does for the free spheres.

    Periodic axes (domain lo, hi in m): a centre of mass and a member placed beyond the box are put back by
    one period (engine/neighbor.py wraps free spheres so at each rebuild), so a clump across the boundary has
    members on both sides; the lever arm x_i - X and a member's travel since the last rebuild are taken as
    the nearest image.
    """
    x = s.x
    v = s.v
    f = s.f
    torque = s.torque
    omega = s.omega
    pid = s.pid
    mass = s.mass
    x_build = s.x_build
    member_body = b.member_body
    member_offset = b.member_offset
    nb = b.mass.shape[0]
    box = hi - lo
    # flags and gravity as locals: read once, not per member (stores to the force arrays might alias them)
    per0 = periodic[0]
    per1 = periodic[1]
    per2 = periodic[2]
    g0 = gravity[0]
    g1 = gravity[1]
    g2 = gravity[2]
    if collect:
        for k in range(nb):
            b.members[k] = 0
            for a in range(3):
                b.force[k, a] = 0.0
                b.torque[k, a] = 0.0
        for i in range(n):
            k = member_body[pid[i]]
            if k < 0:
                continue
            b.members[k] += 1
            mi = mass[i]
            fx = f[i, 0] - mi * g0
            fy = f[i, 1] - mi * g1
            fz = f[i, 2] - mi * g2
            rx = x[i, 0] - b.x[k, 0]
            ry = x[i, 1] - b.x[k, 1]
            rz = x[i, 2] - b.x[k, 2]
            if per0:
                rx -= box[0] * np.rint(rx / box[0])
            if per1:
                ry -= box[1] * np.rint(ry / box[1])
            if per2:
                rz -= box[2] * np.rint(rz / box[2])
            b.force[k, 0] += fx
            b.force[k, 1] += fy
            b.force[k, 2] += fz
            b.torque[k, 0] += torque[i, 0] + ry * fz - rz * fy
            b.torque[k, 1] += torque[i, 1] + rz * fx - rx * fz
            b.torque[k, 2] += torque[i, 2] + rx * fy - ry * fx
            f[i, 0] = mi * g0
            f[i, 1] = mi * g1
            f[i, 2] = mi * g2
            torque[i, 0] = 0.0
            torque[i, 1] = 0.0
            torque[i, 2] = 0.0
        for k in range(nb):
            if b.members[k] > 0:
                for a in range(3):
                    b.force[k, a] += b.mass[k] * gravity[a]
    rot = b.rot
    advance_bodies(b.x, b.v, b.angmom, b.q, b.inertia, b.omega, b.force, b.torque, b.mass, b.members, dt, kick,
                   drift)
    for k in range(nb):
        if b.members[k] == 0:
            continue
        if drift:
            for a in range(3):
                if periodic[a] and (b.x[k, a] < lo[a] or b.x[k, a] >= hi[a]):
                    b.x[k, a] -= box[a] * np.floor((b.x[k, a] - lo[a]) / box[a])
        _rotation(b.q[k, 0], b.q[k, 1], b.q[k, 2], b.q[k, 3], rot[k])
    need = 0
    bad = n
    for i in range(n):
        k = member_body[pid[i]]
        if k < 0:
            continue
        p = pid[i]
        o0 = member_offset[p, 0]
        o1 = member_offset[p, 1]
        o2 = member_offset[p, 2]
        r0 = rot[k, 0, 0] * o0 + rot[k, 0, 1] * o1 + rot[k, 0, 2] * o2
        r1 = rot[k, 1, 0] * o0 + rot[k, 1, 1] * o1 + rot[k, 1, 2] * o2
        r2 = rot[k, 2, 0] * o0 + rot[k, 2, 1] * o1 + rot[k, 2, 2] * o2
        w0 = b.omega[k, 0]
        w1 = b.omega[k, 1]
        w2 = b.omega[k, 2]
        v[i, 0] = b.v[k, 0] + w1 * r2 - w2 * r1
        v[i, 1] = b.v[k, 1] + w2 * r0 - w0 * r2
        v[i, 2] = b.v[k, 2] + w0 * r1 - w1 * r0
        omega[i, 0] = w0
        omega[i, 1] = w1
        omega[i, 2] = w2
        if drift:
            # the position kept in locals: the same values as read back from x, without reloading them
            xi0 = b.x[k, 0] + r0
            xi1 = b.x[k, 1] + r1
            xi2 = b.x[k, 2] + r2
            if per0 and (xi0 < lo[0] or xi0 >= hi[0]):
                xi0 -= box[0] * np.floor((xi0 - lo[0]) / box[0])
            if per1 and (xi1 < lo[1] or xi1 >= hi[1]):
                xi1 -= box[1] * np.floor((xi1 - lo[1]) / box[1])
            if per2 and (xi2 < lo[2] or xi2 >= hi[2]):
                xi2 -= box[2] * np.floor((xi2 - lo[2]) / box[2])
            x[i, 0] = xi0
            x[i, 1] = xi1
            x[i, 2] = xi2
            dx = xi0 - x_build[i, 0]
            dy = xi1 - x_build[i, 1]
            dz = xi2 - x_build[i, 2]
            if per0:
                dx -= box[0] * np.rint(dx / box[0])
            if per1:
                dy -= box[1] * np.rint(dy / box[1])
            if per2:
                dz -= box[2] * np.rint(dz / box[2])
            d2 = dx * dx + dy * dy + dz * dz
            if d2 > half_skin_sq:
                need += 1
            elif not d2 <= half_skin_sq:
                bad = min(bad, i)
    return need, bad


@njit(cache=True, error_model="numpy")
def overlap_statistics(x, radius, pid, member_body, nbr_start, nbr_j, ratio_limit, lo, hi, periodic):
    """(contacts, contacts above ratio_limit of the smaller radius, largest overlap / smaller radius) of the
    listed pairs that are not two members of one body (those overlap by design); nearest images along the
    periodic axes of the domain lo, hi (m)."""
    box = hi - lo
    n_contacts = 0
    n_large = 0
    worst = 0.0
    for i in range(nbr_start.shape[0] - 1):
        bi = member_body[pid[i]]
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if bi >= 0 and member_body[pid[j]] == bi:
                continue
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            if periodic[0]:
                dx -= box[0] * np.rint(dx / box[0])
            if periodic[1]:
                dy -= box[1] * np.rint(dy / box[1])
            if periodic[2]:
                dz -= box[2] * np.rint(dz / box[2])
            n_contacts, n_large, worst = tally_overlap(
                radius[i] + radius[j] - np.sqrt(dx * dx + dy * dy + dz * dz), min(radius[i], radius[j]),
                ratio_limit, n_contacts, n_large, worst)
    return n_contacts, n_large, worst


# ---------------------------------------------------------------- kernel pieces (engine/kernels.py)

#: in the pair loop, after the pair's reaction row is known: two members of one body do not touch
SAME_BODY = """\
if body_i >= 0 and member_body[pid[j]] == body_i:
    ${zero_row}
    continue
"""
SAME_BODY_HEAD = "member_body = bodies.member_body\n"
#: the bodies' pass after each particle pass, and after the first drift of a chunk
BODY_SETUP = "body_pass(s, n, bodies, gravity, dt, True, False, False, 0.0, lo, hi, periodic)\n"
BODY_START = ("need_b, bad_b = body_pass(s, n, bodies, gravity, dt, off, off, on, half_skin_sq, lo, hi, "
              "periodic)\nneed += need_b\nfirst_bad = min(first_bad, bad_b)\n")
BODY_STEP = ("need_b, bad_b = body_pass(s, n, bodies, gravity, dt, on, on, not record, half_skin_sq, lo, hi, "
             "periodic)\n"
             "need += need_b\nfirst_bad = min(first_bad, bad_b)\n")


def member_clear(clear: str, store: str) -> str:
    """What the integration (engine/kernels.py INTEGRATE) does with a particle's force and torque after its
    drift: clear (start the next evaluation: gravity, zero) for free spheres only; a member stores its totals
    (store) instead, since body_pass reads and clears them after the particle pass. Several threads leave a
    free sphere's force as it is (clear is empty: the pair pass assigns it anew)."""
    def indented(code):
        return "".join("    " + line + "\n" for line in code.splitlines() if line.strip())
    if not clear:
        return "if inv_mass[i] == 0.0:\n" + indented(store)
    return "if inv_mass[i] != 0.0:\n" + indented(clear) + "else:\n" + indented(store)


# ---------------------------------------------------------------- Python side: creating bodies


def ensure_ids(sim, next_id: int):
    """The per-id arrays long enough for ids below next_id."""
    b = sim.bodies
    have = len(b.member_body)
    if have >= next_id:
        return
    grow = max(next_id, 2 * have)
    sim.bodies = b._replace(member_body=np.concatenate([b.member_body, np.full(grow - have, -1, dtype=np.int64)]),
                            member_offset=np.concatenate([b.member_offset, np.zeros((grow - have, 3))]))


def add_bodies(sim, template: Template, positions, quaternions, velocity, omega, mid_run: bool = False):
    """Clumps of a template with centres of mass at positions (m, k x 3), orientations (template frame ->
    space, k x 4), one velocity (m/s) and angular velocity (rad/s, space frame). mid_run: inserted at a stop
    of a run (engine/particle_set.py keeps the neighbor list), else created before a run."""

    if sim.bodies is None:
        sim.bodies = empty_bodies(sim.next_id)
    positions = np.array(positions, float).reshape(-1, 3)
    k = len(positions)
    if k == 0:
        return
    if sim.lo is not None:
        # a centre of mass beyond a periodic boundary is put back by one period, as body_pass does
        for a in np.nonzero(sim.periodic)[0]:
            positions[:, a] = sim.lo[a] + np.mod(positions[:, a] - sim.lo[a], sim.hi[a] - sim.lo[a])
    q = np.array([quaternion_product(qu, template.q_axes) for qu in np.asarray(quaternions, float).reshape(-1, 4)])
    rot = rotation_matrices(q)
    members = len(template.radii)
    offsets_space = np.einsum("kab,mb->kma", rot, template.offsets)  # (k, members, 3)
    x = (positions[:, None, :] + offsets_space).reshape(-1, 3)
    omega = np.asarray(omega, float)
    velocity = np.asarray(velocity, float)
    v = (velocity[None, None, :] + np.cross(omega[None, None, :], offsets_space)).reshape(-1, 3)
    total = k * members
    b = sim.bodies
    first_body = len(b.mass)
    inertia = np.tile(template.moments, (k, 1))
    angmom = np.einsum("kab,kb->ka", rot, inertia * np.einsum("kba,b->ka", rot, omega))  # L = R I R^T w
    gravity = sim.gravity_vector()
    mass = np.full(k, template.mass)
    sim.bodies = b._replace(
        x=np.concatenate([b.x, positions]), v=np.concatenate([b.v, np.tile(velocity, (k, 1))]),
        q=np.concatenate([b.q, q]), angmom=np.concatenate([b.angmom, angmom]),
        omega=np.concatenate([b.omega, np.tile(omega, (k, 1))]), inertia=np.concatenate([b.inertia, inertia]),
        mass=np.concatenate([b.mass, mass]),
        force=np.concatenate([b.force, mass[:, None] * gravity[None, :]]),
        torque=np.concatenate([b.torque, np.zeros((k, 3))]),
        members=np.concatenate([b.members, np.full(k, members, dtype=np.int64)]),
        bid=np.concatenate([b.bid, np.arange(first_body + 1, first_body + k + 1, dtype=np.int64)]),
        rot=np.zeros((first_body + k, 3, 3)))
    pid = np.arange(sim.next_id, sim.next_id + total, dtype=np.int64)
    ensure_ids(sim, sim.next_id + total)
    sim.bodies.member_body[pid] = np.repeat(np.arange(first_body, first_body + k), members)
    sim.bodies.member_offset[pid] = np.tile(template.offsets, (k, 1))
    radius = np.tile(template.radii, k)
    member_mass = np.full(total, template.mass)
    arrays = dict(x=x, v=v, omega=np.tile(omega, (total, 1)), radius=radius, mass=member_mass,
                  inv_mass=np.zeros(total), inv_inertia=np.zeros(total),
                  ptype=np.full(total, template.type - 1, dtype=np.int64), pid=pid,
                  f=member_mass[:, None] * gravity[None, :])
    if mid_run:
        particle_set.insert(sim, **arrays)
    else:
        walls, history = sim.state.wall_hist.shape[1:]
        sim.state = particle_state.append(sim.state, x_build=x, wall_hist=np.zeros((total, walls, history)), **arrays)
        sim.dirty = True
    sim.next_id += total


def whole_bodies(sim, mask: np.ndarray) -> np.ndarray:
    """mask widened to every member of a body one of whose members it holds (an outlet takes whole clumps)."""
    if sim.bodies is None or not len(sim.bodies.mass):
        return mask
    body = sim.bodies.member_body[sim.state.pid]
    hit = np.zeros(len(sim.bodies.mass) + 1, dtype=bool)
    hit[body[mask] + 1] = True
    hit[0] = False
    return mask | hit[body + 1]


def recount(sim):
    """Members present per body, after particles were removed between two steps (the body pass counts them
    at every force evaluation)."""
    if sim.bodies is None:
        return
    body = sim.bodies.member_body[sim.state.pid]
    sim.bodies.members[:] = np.bincount(body[body >= 0], minlength=len(sim.bodies.mass))


# ---------------------------------------------------------------- quantities


def _present(sim) -> np.ndarray:
    """Bodies with members present (a body whose members all left keeps its row, with zero members)."""
    return sim.bodies.members > 0


def free(sim) -> np.ndarray:
    """Particles that are free spheres (not members of a clump)."""
    return sim.bodies.member_body[sim.state.pid] < 0


def body_selection(sim, mask) -> np.ndarray:
    """Bodies a particle selection picks: those whose member with the lowest id it holds."""
    b = sim.bodies
    pid = sim.state.pid
    body = b.member_body[pid]
    picked = np.zeros(len(b.mass), dtype=bool)
    selected = np.zeros(len(pid), dtype=bool)
    selected[mask] = True
    members = np.nonzero(body >= 0)[0]
    if len(members):
        order = members[np.lexsort((pid[members], body[members]))]
        first = order[np.r_[True, body[order][1:] != body[order][:-1]]]
        picked[body[first]] = selected[first]
    return picked & _present(sim)


def _selected(sim, mask):
    """(state, free spheres selected, bodies, bodies selected): what an energy of the selection sums over."""
    s = sim.state
    keep = np.zeros(len(s.pid), dtype=bool)
    keep[mask] = True
    keep &= free(sim)
    return s, keep, sim.bodies, body_selection(sim, mask)


def kinetic_energy(sim, mask=slice(None)) -> float:
    """J: 1/2 m v^2 of the free spheres selected plus 1/2 M V^2 of the bodies selected."""
    s, keep, b, pick = _selected(sim, mask)
    return float(0.5 * np.sum(s.mass[keep] * np.einsum("ij,ij->i", s.v[keep], s.v[keep]))
                 + 0.5 * np.sum(b.mass[pick] * np.einsum("ij,ij->i", b.v[pick], b.v[pick])))


def rotational_energy(sim, mask=slice(None)) -> float:
    """J: 0.2 m r^2 w^2 of the free spheres selected plus 1/2 L.w of the bodies selected."""
    s, keep, b, pick = _selected(sim, mask)
    return float(0.2 * np.sum(s.mass[keep] * s.radius[keep] ** 2 * np.einsum("ij,ij->i", s.omega[keep],
                                                                               s.omega[keep]))
                 + 0.5 * np.sum(np.einsum("ij,ij->i", b.angmom[pick], b.omega[pick])))


def masses_and_positions(sim, mask=slice(None)):
    """(masses, positions, velocities) of the free spheres and the bodies (centres of mass) selected."""
    s = sim.state
    keep = np.zeros(len(s.pid), dtype=bool)
    keep[mask] = True
    keep &= free(sim)
    b = sim.bodies
    pick = body_selection(sim, mask)
    return (np.concatenate([s.mass[keep], b.mass[pick]]), np.concatenate([s.x[keep], b.x[pick]]),
            np.concatenate([s.v[keep], b.v[pick]]))


#: per body: body_NAME[ID] with ID the body id (from 1, in creation order)
BODY_QUANTITIES = {
    "x": ("x", 0), "y": ("x", 1), "z": ("x", 2), "vx": ("v", 0), "vy": ("v", 1), "vz": ("v", 2),
    "omegax": ("omega", 0), "omegay": ("omega", 1), "omegaz": ("omega", 2),
    "lx": ("angmom", 0), "ly": ("angmom", 1), "lz": ("angmom", 2),
    "qw": ("q", 0), "qx": ("q", 1), "qy": ("q", 2), "qz": ("q", 3),
    "w1": ("body_omega", 0), "w2": ("body_omega", 1), "w3": ("body_omega", 2),
}


def body_value(sim, name: str, bid: int) -> float:
    """A per-body quantity (units: m, m/s, rad/s, kg m^2/s; w1..w3 the angular velocity in the body frame,
    along the principal axes with the smallest moment first); NaN when the body is not present."""
    b = sim.bodies
    if b is None:
        return math.nan
    where = np.nonzero((b.bid == bid) & _present(sim))[0]
    if len(where) == 0:
        return math.nan
    k = where[0]
    field, component = BODY_QUANTITIES[name]
    if field == "body_omega":
        rot = rotation_matrices(b.q[k:k + 1])[0]
        return float((rot.T @ b.omega[k])[component])
    return float(getattr(b, field)[k, component])


def overlaps(sim, ratio_limit: float):
    s = sim.state
    return overlap_statistics(s.x, s.radius, s.pid, sim.bodies.member_body, sim.nbr.start, sim.nbr.j, ratio_limit,
                              sim.lo, sim.hi, sim.periodic)


# ---------------------------------------------------------------- restart files

#: restart arrays of the bodies: file key -> Bodies field
RESTART_ARRAYS = {f"clump_{name}": name for name in Bodies._fields if name != "rot"}


def restart_arrays(sim) -> dict:
    if sim.bodies is None:
        return {}
    return {key: getattr(sim.bodies, name) for key, name in RESTART_ARRAYS.items()}


def restore(sim, data: dict):
    """The bodies of a restart file (none when it holds none), checked against its particles."""
    if "clump_mass" not in data:  # no clumps yet; an insert modifier of a template may still add some
        sim.bodies = None if sim.bodies is None else empty_bodies(int(data["next_id"]))
        return
    arrays = {name: np.ascontiguousarray(data[key]) for key, name in RESTART_ARRAYS.items()}
    nb = len(arrays["mass"])
    ids = len(arrays["member_body"])
    shapes = dict(x=(nb, 3), v=(nb, 3), q=(nb, 4), angmom=(nb, 3), omega=(nb, 3), inertia=(nb, 3), mass=(nb,),
                  force=(nb, 3), torque=(nb, 3), members=(nb,), bid=(nb,), member_body=(ids,),
                  member_offset=(ids, 3))
    for name, shape in shapes.items():
        if arrays[name].shape != shape or not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"array 'clump_{name}' has shape {arrays[name].shape}, expected {shape}, or "
                             "non-finite values")
    pid = data["pid"]
    if ids < int(data["next_id"]) or np.any(arrays["member_body"] >= nb) or np.any(arrays["mass"] <= 0) \
            or np.any(arrays["inertia"] <= 0):
        raise ValueError("the clump arrays do not fit the particles")
    if len(pid) and np.any(arrays["member_body"][pid] >= 0) and np.any(data["inv_mass"][arrays["member_body"][pid] >= 0] != 0):
        raise ValueError("a clump member with a mass of its own")
    arrays["members"] = arrays["members"].astype(np.int64)
    arrays["bid"] = arrays["bid"].astype(np.int64)
    arrays["member_body"] = arrays["member_body"].astype(np.int64)
    sim.bodies = Bodies(rot=np.zeros((nb, 3, 3)), **arrays)


def templates_json(sim) -> str:
    return json.dumps([t.definition() for t in sim.clump_templates.values()])
