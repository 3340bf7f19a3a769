"""Pure contact laws: one function per submodel, scalars in, scalars out (SI units).

Every function is a pure function of the contact geometry and the pair's material parameters, after the
LIGGGHTS 3.8 sources named in each docstring (see /work/shared/physics.md). The kernel builder
(`engine.kernels`) pastes calls to exactly the submodels a scene names into one compiled pair loop.

Conventions (all laws): ``en`` is the unit normal pointing from j to i (from the wall to the particle), ``d``
the overlap (m, > 0 in contact), ``vn = (v_i - v_j) . en`` (m/s, < 0 while approaching). A returned force
is the force on i; j receives its negative.
"""
from math import log, pi, sqrt

from .jit import njit


def restitution_beta(restitution):
    """beta = ln(e) / sqrt(ln(e)^2 + pi^2) (<= 0), LIGGGHTS ``normal_model_hertz.h``; e in (0, 1]."""
    le = log(restitution)
    return le / sqrt(le * le + pi * pi)


def effective_youngs_modulus(y_i, nu_i, y_j, nu_j):
    """Y* (Pa): 1/Y* = (1-nu_i^2)/Y_i + (1-nu_j^2)/Y_j (LIGGGHTS ``global_properties.cpp``)."""
    return 1.0 / ((1.0 - nu_i * nu_i) / y_i + (1.0 - nu_j * nu_j) / y_j)


def effective_shear_modulus(y_i, nu_i, y_j, nu_j):
    """G* (Pa): 1/G* = 2(2-nu_i)(1+nu_i)/Y_i + 2(2-nu_j)(1+nu_j)/Y_j (LIGGGHTS ``global_properties.cpp``)."""
    return 1.0 / (2.0 * (2.0 - nu_i) * (1.0 + nu_i) / y_i + 2.0 * (2.0 - nu_j) * (1.0 + nu_j) / y_j)


@njit(cache=True, error_model="numpy")
def hertz_normal(overlap, vn, ystar, gstar, beta, reff, meff):
    """Hertz normal force (LIGGGHTS ``normal_model_hertz.h``).

    Sn = 2 Y* sqrt(R* d), St = 8 G* sqrt(R* d), kn = 4/3 Y* sqrt(R* d), kt = St,
    gn = -2 sqrt(5/6) beta sqrt(Sn m*), gt = -2 sqrt(5/6) beta sqrt(St m*), Fn = kn d - gn vn.

    overlap: m, vn: m/s, ystar/gstar: Pa, beta: -, reff: m, meff: kg.
    Returns (Fn N, kn N/m, kt N/m, gn kg/s, gt kg/s).
    """
    sqrt_rd = sqrt(reff * overlap)
    sn = 2.0 * ystar * sqrt_rd
    st = 8.0 * gstar * sqrt_rd
    kn = 4.0 / 3.0 * ystar * sqrt_rd
    gn = -2.0 * 0.9128709291752769 * beta * sqrt(sn * meff)  # 0.91287... = sqrt(5/6)
    gt = -2.0 * 0.9128709291752769 * beta * sqrt(st * meff)
    return kn * overlap - gn * vn, kn, st, gn, gt


@njit(cache=True, error_model="numpy")
def hooke_normal(overlap, vn, ystar, log_restitution, reff, meff, characteristic_velocity):
    """Hooke normal force (LIGGGHTS ``normal_model_hooke.h``).

    kn = 16/15 sqrt(R*) Y* (15 m* V^2 / (16 sqrt(R*) Y*))^(1/5), kt = kn,
    gn = sqrt(4 m* kn ln(e)^2 / (ln(e)^2 + pi^2)), gt = gn, Fn = kn d - gn vn.

    characteristic_velocity V: m/s. Returns (Fn N, kn N/m, kt N/m, gn kg/s, gt kg/s).
    """
    sqrt_r = sqrt(reff)
    kn = 16.0 / 15.0 * sqrt_r * ystar * (15.0 * meff * characteristic_velocity * characteristic_velocity
                                         / (16.0 * sqrt_r * ystar)) ** 0.2
    le2 = log_restitution * log_restitution
    gn = sqrt(4.0 * meff * kn * le2 / (le2 + pi * pi))
    return kn * overlap - gn * vn, kn, kn, gn, gn


@njit(cache=True, error_model="numpy")
def sjkr_pair_force(r, r_i, r_j, cohesion_energy_density):
    """SJKR cohesion between two spheres (LIGGGHTS ``cohesion_model_sjkr.h``): F = -k A (along en, attractive).

    A = -pi/4 (r-ri-rj)(r+ri-rj)(r-ri+rj)(r+ri+rj) / r^2 is the area of the circle where the two spheres
    intersect (m^2); k: J/m^3. Returns the normal force increment (N, <= 0).
    """
    area = -0.25 * pi * (r - r_i - r_j) * (r + r_i - r_j) * (r - r_i + r_j) * (r + r_i + r_j) / (r * r)
    return -cohesion_energy_density * area


@njit(cache=True, error_model="numpy")
def sjkr_wall_force(distance, r_i, cohesion_energy_density):
    """SJKR cohesion sphere-wall: F = -k pi (ri^2 - dist^2), dist = centre-wall distance (m). Returns N (<= 0)."""
    return -cohesion_energy_density * pi * (r_i * r_i - distance * distance)


@njit(cache=True, error_model="numpy")
def slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz):
    """Tangential slip velocity of i relative to j at the contact point (m/s).

    vtr = vt + en x wr with vt = vr - vn en and wr = cr_i w_i + cr_j w_j (m/s). This is the sign used in
    LIGGGHTS ``surface_model_default.h`` (vtr1 = vt1 - (enz wr2 - eny wr3)); physics.md writes the cross
    product the other way round but describes the same physical slip velocity.
    """
    vtx = vrx - vn * enx
    vty = vry - vn * eny
    vtz = vrz - vn * enz
    return (vtx + (eny * wrz - enz * wry), vty + (enz * wrx - enx * wrz), vtz + (enx * wry - eny * wrx))


@njit(cache=True, error_model="numpy")
def tangential_history(sx, sy, sz, vtx, vty, vtz, enx, eny, enz, kt, gt, friction, fn, dt):
    """Tangential force with history and Coulomb limit (LIGGGHTS 3.8 ``tangential_model_history.h``).

    xi += vtr dt, projected onto the tangent plane (no rescaling); Ft = -kt xi; if kt |xi| > mu |Fn| the
    contact slides: Ft scaled to mu |Fn| and xi = -Ft / kt (no damping); else it sticks: Ft = -kt xi - gt vtr.
    s*: shear displacement xi (m), vt*: slip velocity (m/s), kt: N/m, gt: kg/s, fn: N, dt: s.
    Returns (Ftx, Fty, Ftz, new xi x, y, z).
    """
    sx += vtx * dt
    sy += vty * dt
    sz += vtz * dt
    proj = sx * enx + sy * eny + sz * enz
    sx -= proj * enx
    sy -= proj * eny
    sz -= proj * enz
    shear_mag = sqrt(sx * sx + sy * sy + sz * sz)
    ftx = -kt * sx
    fty = -kt * sy
    ftz = -kt * sz
    f_friction = friction * abs(fn)
    if kt * shear_mag > f_friction:
        if shear_mag != 0.0:
            ratio = f_friction / (kt * shear_mag)
            ftx *= ratio
            fty *= ratio
            ftz *= ratio
            sx = -ftx / kt
            sy = -fty / kt
            sz = -ftz / kt
        else:
            ftx = 0.0
            fty = 0.0
            ftz = 0.0
    else:
        ftx -= gt * vtx
        fty -= gt * vty
        ftz -= gt * vtz
    return ftx, fty, ftz, sx, sy, sz


@njit(cache=True, error_model="numpy")
def tangential_no_history(vtx, vty, vtz, gt, friction, fn):
    """Viscous tangential force capped by Coulomb (LIGGGHTS ``tangential_model_no_history.h``).

    g = min(gt, mu |Fn| / |vtr|), Ft = -g vtr. Returns (Ftx, Fty, Ftz) in N.
    """
    vmag = sqrt(vtx * vtx + vty * vty + vtz * vtz)
    if vmag == 0.0:
        return 0.0, 0.0, 0.0
    g = min(gt, friction * abs(fn) / vmag)
    return -g * vtx, -g * vty, -g * vtz


@njit(cache=True, error_model="numpy")
def rolling_cdt(wx, wy, wz, enx, eny, enz, rolling_friction, elastic_normal_force, lever):
    """Constant directional torque rolling friction (LIGGGHTS ``rolling_model_cdt.h``).

    w = w_i - w_j with its normal (torsion) part removed; T = mu_r (kn d) R* w / |w| (N m), kn d the elastic
    normal force (N), R* the lever (m; r_i for walls). Torque on i is -T, on j +T.
    """
    wn = wx * enx + wy * eny + wz * enz
    wx -= wn * enx
    wy -= wn * eny
    wz -= wn * enz
    wmag = sqrt(wx * wx + wy * wy + wz * wz)
    if wmag == 0.0:
        return 0.0, 0.0, 0.0
    scale = rolling_friction * elastic_normal_force * lever / wmag
    return scale * wx, scale * wy, scale * wz


@njit(cache=True, error_model="numpy")
def rolling_epsd2(mx, my, mz, wx, wy, wz, enx, eny, enz, kt, reff, rolling_friction, fn, dt):
    """Elastic-plastic spring-dashpot rolling resistance, EPSD2 (LIGGGHTS ``rolling_model_epsd2.h``).

    kr = kt R*^2; M += kr w dt with w = w_i - w_j, its normal part removed; |M| capped at mu_r R* |Fn|.
    m*: stored rolling torque (N m). Returns (new M x, y, z); torque on i is -M, on j +M.
    """
    wn = wx * enx + wy * eny + wz * enz
    wx -= wn * enx
    wy -= wn * eny
    wz -= wn * enz
    kr = kt * reff * reff
    mx += kr * wx * dt
    my += kr * wy * dt
    mz += kr * wz * dt
    mmag = sqrt(mx * mx + my * my + mz * mz)
    m_max = rolling_friction * reff * abs(fn)
    if mmag > m_max:
        ratio = m_max / mmag
        mx *= ratio
        my *= ratio
        mz *= ratio
    return mx, my, mz
