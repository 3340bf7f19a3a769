"""Each submodel's force against values computed by hand from the formulas in physics.md."""
import math

import numpy as np
import pytest

from engine import contact_laws as cl


def test_material_mixing():
    ystar = cl.effective_youngs_modulus(1e7, 0.3, 2e7, 0.25)
    assert ystar == pytest.approx(1.0 / ((1 - 0.09) / 1e7 + (1 - 0.0625) / 2e7))
    gstar = cl.effective_shear_modulus(1e7, 0.3, 1e7, 0.3)
    assert gstar == pytest.approx(1.0 / (2 * 2 * 1.7 * 1.3 / 1e7))
    assert cl.restitution_beta(1.0) == 0.0
    assert cl.restitution_beta(0.5) == pytest.approx(math.log(0.5) / math.sqrt(math.log(0.5) ** 2 + math.pi ** 2))


def test_hertz_normal_by_hand():
    d, vn, ystar, gstar, beta, reff, meff = 1e-4, -0.3, 5e6, 2e6, -0.2, 5e-3, 1e-3
    fn, kn, kt, gn, gt = cl.hertz_normal(d, vn, ystar, gstar, beta, reff, meff)
    root = math.sqrt(reff * d)
    assert kn == pytest.approx(4 / 3 * ystar * root)
    assert kt == pytest.approx(8 * gstar * root)
    assert gn == pytest.approx(-2 * math.sqrt(5 / 6) * beta * math.sqrt(2 * ystar * root * meff))
    assert gt == pytest.approx(-2 * math.sqrt(5 / 6) * beta * math.sqrt(8 * gstar * root * meff))
    # elastic part 4/3 Y* sqrt(R*) d^1.5 plus damping -gn vn (repulsive while approaching)
    assert fn == pytest.approx(4 / 3 * ystar * math.sqrt(reff) * d ** 1.5 - gn * vn)
    assert gn > 0 and fn > 4 / 3 * ystar * math.sqrt(reff) * d ** 1.5


def test_hooke_normal_by_hand():
    d, vn, ystar, e, reff, meff, vchar = 2e-4, 0.1, 1e7, 0.7, 1e-2, 4e-3, 1.5
    fn, kn, kt, gn, gt = cl.hooke_normal(d, vn, ystar, math.log(e), reff, meff, vchar)
    kn_hand = 16 / 15 * math.sqrt(reff) * ystar * (15 * meff * vchar ** 2 / (16 * math.sqrt(reff) * ystar)) ** 0.2
    gn_hand = math.sqrt(4 * meff * kn_hand * math.log(e) ** 2 / (math.log(e) ** 2 + math.pi ** 2))
    assert kn == pytest.approx(kn_hand) and kt == kn
    assert gn == pytest.approx(gn_hand) and gt == gn
    assert fn == pytest.approx(kn_hand * d - gn_hand * vn)


def test_slip_velocity_of_rolling_sphere_is_zero():
    # sphere of radius r rolling in +x on a floor (en = +z from the floor to the sphere): w_y = +v/r
    r, v = 0.01, 0.2
    vt = cl.slip_velocity(v, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, r * v / r, 0.0)
    assert np.allclose(vt, 0.0)
    # spinning the other way doubles the slip
    vt = cl.slip_velocity(v, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -v, 0.0)
    assert vt == pytest.approx((2 * v, 0.0, 0.0))


def test_tangential_history_stick():
    en = (0.0, 0.0, 1.0)
    shear = (1e-6, 0.0, 3e-7)  # the normal part must be projected away
    vt, kt, gt, mu, fn, dt = (0.01, -0.02, 0.0), 1e4, 0.5, 0.5, 10.0, 1e-5
    ftx, fty, ftz, sx, sy, sz = cl.tangential_history(*shear, *vt, *en, kt, gt, mu, fn, dt)
    xi = np.array([1e-6 + 0.01 * dt, -0.02 * dt, 0.0])
    assert (sx, sy, sz) == pytest.approx(tuple(xi))
    assert (ftx, fty, ftz) == pytest.approx(tuple(-kt * xi - gt * np.array(vt)))


def test_tangential_history_slip_caps_at_coulomb():
    en = (1.0, 0.0, 0.0)
    vt, kt, gt, mu, fn, dt = (0.0, 0.5, 0.0), 1e5, 2.0, 0.3, 2.0, 1e-4
    ftx, fty, ftz, sx, sy, sz = cl.tangential_history(0.0, 1e-4, 0.0, *vt, *en, kt, gt, mu, fn, dt)
    # kt |xi| = 1e5 * 1.5e-4 = 15 N > mu Fn = 0.6 N: slides with |Ft| = 0.6 N against the displacement
    assert (ftx, fty, ftz) == pytest.approx((0.0, -0.6, 0.0))
    assert (sx, sy, sz) == pytest.approx((0.0, 0.6 / kt, 0.0))


def test_tangential_no_history():
    vt = (0.3, 0.4, 0.0)  # |vt| = 0.5
    assert cl.tangential_no_history(*vt, 2.0, 0.5, 10.0) == pytest.approx((-0.6, -0.8, 0.0))  # viscous, g = gt
    assert cl.tangential_no_history(*vt, 2.0, 0.05, 10.0) == pytest.approx((-0.3, -0.4, 0.0))  # g = mu Fn/|vt| = 1
    assert cl.tangential_no_history(0.0, 0.0, 0.0, 2.0, 0.5, 10.0) == (0.0, 0.0, 0.0)


def test_sjkr_pair_and_wall_by_hand():
    ri, rj, r, k = 0.01, 0.02, 0.029, 1e5
    # intersection circle radius a: a^2 = ri^2 - ((r^2 + ri^2 - rj^2) / (2 r))^2
    h = (r * r + ri * ri - rj * rj) / (2 * r)
    area = math.pi * (ri * ri - h * h)
    assert cl.sjkr_pair_force(r, ri, rj, k) == pytest.approx(-k * area)
    assert cl.sjkr_wall_force(0.009, 0.01, k) == pytest.approx(-k * math.pi * (1e-4 - 0.81e-4))


def test_rolling_cdt_by_hand():
    en = (0.0, 0.0, 1.0)
    w = (0.0, -3.0, 5.0)  # torsion part (z) is removed
    tx, ty, tz = cl.rolling_cdt(*w, *en, 0.1, 20.0, 0.005)
    assert (tx, ty, tz) == pytest.approx((0.0, -0.1 * 20.0 * 0.005, 0.0))
    assert cl.rolling_cdt(0.0, 0.0, 4.0, *en, 0.1, 20.0, 0.005) == (0.0, 0.0, 0.0)


def test_rolling_epsd2_spring_then_cap():
    en = (1.0, 0.0, 0.0)
    kt, reff, mu_r, fn, dt = 1e4, 0.01, 0.2, 5.0, 1e-4
    m = cl.rolling_epsd2(0.0, 0.0, 0.0, 7.0, 2.0, 0.0, *en, kt, reff, mu_r, fn, dt)
    assert m == pytest.approx((0.0, kt * reff ** 2 * 2.0 * dt, 0.0))  # elastic: kr w dt, normal part gone
    m = cl.rolling_epsd2(0.0, 1.0, 0.0, 0.0, 2.0, 0.0, *en, kt, reff, mu_r, fn, dt)
    assert m == pytest.approx((0.0, mu_r * reff * fn, 0.0))  # plastic: capped at mu_r R* |Fn|
