"""Analytic checks of the whole engine (run as a program on small scenes)."""
import math

import numpy as np
import pytest

from conftest import (domain, gravity, interaction, material, model, particle, plane, printer, read_csv, run,
                      timestep)

R = 0.01  # m
RHO = 2500.0  # kg/m^3
MASS = RHO * 4 / 3 * math.pi * R ** 3
Y, NU = 1e7, 0.3
YSTAR = 1 / (2 * (1 - NU ** 2) / Y)  # same material on both sides


def hooke_scene(e, extra):
    """Hooke without friction, no gravity; a far-away plane and cylinder keep every Hooke test on one kernel."""
    return [domain(), material(y=Y, nu=NU, rho=RHO), interaction(e=e),
            model("hooke", "none", characteristic_velocity=1.0),
            plane("far", "x", -0.4),
            {"command": "create", "object": "wall", "name": "drum", "shape": "cylinder", "center": [0, 0],
             "radius": 0.5, "side": "inside", "type": 1},
            timestep(1e-5)] + extra


def hertz_scene(extra, e=0.5, mu=0.3, g=(0, 0, -9.81), **interaction_extra):
    """Hertz + tangential history + a floor at z = 0 + gravity (set to 0 where a test needs none)."""
    return [domain(), material(y=Y, nu=NU, rho=RHO), interaction(e=e, mu=mu, **interaction_extra),
            model("hertz", "history"), plane("floor", "z", 0.0)] + gravity(g) + extra


def test_free_fall_is_exact(engine_run):
    dt, steps = 1e-4, 3000
    code, folder = engine_run(hertz_scene([particle([0, 0, 0.9]), timestep(dt)]
                                          + printer(100, ["z[1]", "vz[1]"]) + [run(steps)]))
    assert code == 0
    s = read_csv(folder / "series.csv")
    t = s["step"] * dt
    # Velocity-Verlet integrates a constant acceleration exactly (up to round-off)
    assert np.allclose(s["z[1]"], 0.9 - 0.5 * 9.81 * t ** 2, rtol=0, atol=1e-12)
    assert np.allclose(s["vz[1]"], -9.81 * t, rtol=0, atol=1e-12)


def test_hooke_particle_wall_restitution(engine_run):
    e = 0.9
    scene = hooke_scene(e, [particle([-0.4 + R + 1e-4, 0, 0], velocity=[-1.0, 0, 0])]
                        + printer(700, ["vx[1]"]) + [run(700)])
    code, folder = engine_run(scene)
    assert code == 0
    assert read_csv(folder / "series.csv")["vx[1]"][-1] == pytest.approx(e * 1.0, rel=0.01)


def test_hooke_particle_cylinder_restitution(engine_run):
    e = 0.9
    scene = hooke_scene(e, [particle([0.5 - R - 1e-4, 0, 0], velocity=[1.0, 0, 0])]
                        + printer(700, ["vx[1]"]) + [run(700)])
    code, folder = engine_run(scene)
    assert code == 0
    assert read_csv(folder / "series.csv")["vx[1]"][-1] == pytest.approx(-e, rel=0.01)


def test_hooke_particle_particle_restitution(engine_run):
    e = 0.8
    scene = hooke_scene(e, [particle([-R - 1e-4, 0, 0], velocity=[0.5, 0, 0]),
                            particle([R + 1e-4, 0, 0], velocity=[-0.5, 0, 0])]
                        + printer(800, ["vx[1]", "vx[2]"]) + [run(800)])
    code, folder = engine_run(scene)
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["vx[2]"][-1] - s["vx[1]"][-1] == pytest.approx(e * 1.0, rel=0.01)
    assert s["vx[1]"][-1] + s["vx[2]"][-1] == pytest.approx(0.0, abs=1e-12)  # momentum


def test_hertz_elastic_contact_time(engine_run):
    dt, v = 2e-6, 1.0
    scene = hertz_scene([particle([0, 0, 0.5], velocity=[v / 2, 0, 0]),
                         particle([2 * R + 2e-6, 0, 0.5], velocity=[-v / 2, 0, 0]), timestep(dt)]
                        + printer(1, ["x[1]", "x[2]"]) + [run(1600)], e=1.0, mu=0.0, g=(0, 0, 0))
    code, folder = engine_run(scene)
    assert code == 0
    s = read_csv(folder / "series.csv")
    in_contact = (s["x[2]"] - s["x[1]"]) < 2 * R
    assert not in_contact[-1]  # separated again
    measured = in_contact.sum() * dt
    m_eff, r_eff = MASS / 2, R / 2
    expected = 2.87 * (m_eff ** 2 / (r_eff * YSTAR ** 2 * v)) ** 0.2
    assert measured == pytest.approx(expected, rel=0.02)


def test_sliding_sphere_ends_rolling_at_five_sevenths(engine_run):
    v0 = 1.0
    scene = hertz_scene([particle([0, 0, R], velocity=[v0, 0, 0]), timestep(1e-5)]
                        + printer(500, ["vx[1]", "omegay[1]"]) + [run(15000)], e=0.5, mu=0.3)
    code, folder = engine_run(scene)
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["vx[1]"][-1] == pytest.approx(5 / 7 * v0, rel=0.02)
    assert s["omegay[1]"][-1] * R == pytest.approx(s["vx[1]"][-1], rel=0.02)  # rolls without slip
    # while sliding it decelerates at mu g
    slope = np.polyfit(s["step"][2:8] * 1e-5, s["vx[1]"][2:8], 1)[0]
    assert slope == pytest.approx(-0.3 * 9.81, rel=0.03)


def test_cdt_rolling_friction_stops_sphere_at_rate_mu_r(engine_run):
    v0, mu_r, dt = 0.2, 0.2, 1e-5
    scene = [domain(), material(y=Y, nu=NU, rho=RHO), interaction(e=0.5, mu=0.5, rolling_friction=mu_r),
             model("hertz", "history", rolling="cdt"), plane("floor", "z", 0.0)] + gravity() + [
        particle([0, 0, R - MASS * 9.81 / (2 * YSTAR * R)], velocity=[v0, 0, 0], omega=[0, v0 / R, 0]),
        timestep(dt)] + printer(500, ["vx[1]"]) + [run(20000)]
    code, folder = engine_run(scene)
    assert code == 0
    s = read_csv(folder / "series.csv")
    t, vx = s["step"] * dt, s["vx[1]"]
    rolling = (t > 0.01) & (t < 0.1)
    decel = -np.polyfit(t[rolling], vx[rolling], 1)[0]
    assert decel == pytest.approx(5 / 7 * mu_r * 9.81, rel=0.03)  # a = mu_r m g R / (R (m + I/R^2))
    assert abs(vx[-1]) < 0.02 * v0  # stopped after v0 / a = 0.146 s


def test_momentum_and_count_in_periodic_box(engine_run):
    rng = np.random.default_rng(7)
    grid = np.stack(np.meshgrid(*[np.arange(3) * 0.013 + 0.006] * 3, indexing="ij"), -1).reshape(-1, 3)
    velocities = rng.normal(0, 0.5, (len(grid), 3))
    scene = [domain((0, 0, 0), (0.04, 0.04, 0.04), (True, True, True)), material(y=Y, nu=NU, rho=RHO),
             interaction(e=0.5, mu=0.3), model("hertz", "history")] + gravity((0, 0, 0)) + [
        particle(p, radius=0.005, velocity=v) for p, v in zip(grid, velocities)] + [
        timestep(1e-5), {"command": "set", "property": "thermo", "every": 1000,
                         "columns": ["momentum_x", "momentum_y", "momentum_z"]}, run(6000)]
    code, folder = engine_run(scene)
    assert code == 0
    th = read_csv(folder / "thermo.csv")
    assert np.all(th["atoms"] == len(grid))
    p0 = MASS / 8 * velocities.sum(axis=0)  # r = 5 mm: an eighth of the 10 mm sphere's mass
    for a, axis in enumerate("xyz"):
        assert np.allclose(th[f"momentum_{axis}"], p0[a], rtol=0, atol=1e-14)
    assert th["ke"][-1] < 0.8 * th["ke"][0]  # particles did collide (e = 0.5)


def test_closed_box_keeps_every_particle(engine_run):
    walls = [plane(f"{axis}{side}", axis, side * 0.03) for axis in "xyz" for side in (-1, 1)]
    scene = [domain((-0.05, -0.05, -0.05), (0.05, 0.05, 0.05)), material(y=Y, nu=NU, rho=RHO),
             interaction(e=0.5, mu=0.3), model("hertz", "history")] + walls + gravity() + [
        {"command": "create", "object": "random_packing", "type": 1, "count": 40, "seed": 3, "radius_min": 0.003,
         "radius_max": 0.004, "velocity": [0.3, -0.2, 0.0],
         "region": {"shape": "box", "lo": [-0.03, -0.03, -0.03], "hi": [0.03, 0.03, 0.03]}},
        timestep(1e-5), {"command": "set", "property": "thermo", "every": 1000, "columns": ["com_z"]}, run(8000)]
    code, folder = engine_run(scene)
    assert code == 0
    th = read_csv(folder / "thermo.csv")
    assert np.all(th["atoms"] == 40)
    assert th["com_z"][-1] < th["com_z"][0]  # fell
    assert "left the fixed domain" not in (folder / "log.dem").read_text()


def test_particles_leaving_fixed_domain_are_removed_and_reported(engine_run):
    scene = hertz_scene([domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), particle([0, 0, 0.05], velocity=[5, 0, 0]),
                         particle([0, 0.05, 0.05]), timestep(1e-4),
                         {"command": "set", "property": "thermo", "every": 100}, run(400)], g=(0, 0, 0))
    code, folder = engine_run(scene)
    assert code == 0
    th = read_csv(folder / "thermo.csv")
    assert th["atoms"][0] == 2 and th["atoms"][-1] == 1
    log = (folder / "log.dem").read_text()
    assert "WARNING: 1 particle(s) left the fixed domain and were removed (ids 1" in log


def test_cohesion_holds_sphere_under_ceiling(engine_run):
    """SJKR between wall and sphere: enough cohesion energy density holds a sphere against gravity."""
    def scene(k):
        return [domain(), material(y=Y, nu=NU, rho=RHO),
                interaction(e=0.5, mu=0.3, cohesion_energy_density=k, rolling_friction=0.1),
                model("hertz", "history", cohesion="sjkr", rolling="epsd2"), plane("ceiling", "z", 0.5),
                {"command": "create", "object": "wall", "name": "drum", "shape": "cylinder", "center": [0, 0],
                 "radius": 0.8, "side": "inside", "type": 1}] + gravity() + [
            particle([0, 0, 0.5 - R + 1e-5]), timestep(1e-5)] + printer(3000, ["z[1]"]) + [run(3000)]
    code, folder = engine_run(scene(5e5), sub="sticky")
    assert code == 0
    assert read_csv(folder / "series.csv")["z[1]"][-1] > 0.5 - R
    code, folder = engine_run(scene(0.0), sub="loose")
    assert code == 0
    assert read_csv(folder / "series.csv")["z[1]"][-1] == pytest.approx(0.5 - R + 1e-5 - 0.5 * 9.81 * 0.03 ** 2, abs=2e-4)


def test_moving_plane_lifts_resting_sphere(engine_run):
    """A floor moving up at constant speed carries the sphere on it at that speed (wall velocity enters vr)."""
    lift = 0.05
    scene = [domain(), material(y=Y, nu=NU, rho=RHO), interaction(e=0.5, mu=0.3), model("hertz", "history"),
             plane("lift", "z", 0.0, velocity=(0, 0, lift))] + gravity() + [
        particle([0, 0, R]), timestep(1e-5)] + printer(2000, ["z[1]", "vz[1]"]) + [run(20000)]
    code, folder = engine_run(scene)
    assert code == 0
    s = read_csv(folder / "series.csv")
    assert s["vz[1]"][-1] == pytest.approx(lift, rel=0.02)
    # resting on the plane (at z = lift t) with its static overlap m g / kn
    assert s["z[1]"][-1] == pytest.approx(lift * 0.2 + R, abs=0.02 * R)


def test_wall_force_of_a_resting_sphere_is_its_weight(engine_run):
    scene = hertz_scene([plane("side", "x", 0.5), particle([0, 0, R]), timestep(1e-5),
                         {"command": "set", "property": "thermo", "every": 1000,
                          "columns": ["wall_fz[floor]", "wall_fx[side]"]}, run(10000)])
    code, folder = engine_run(scene)
    assert code == 0
    th = read_csv(folder / "thermo.csv")
    assert th["wall_fz[floor]"][-1] == pytest.approx(-MASS * 9.81, rel=1e-3)  # pressed down by its weight
    assert np.all(th["wall_fx[side]"] == 0.0)
