"""Plots as data (webfrontend.plots): titles, axis labels with units, legends, acceptance bands that agree
with the check, expectations, differences, a bounded consistency axis, sweeps on log axes."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from dashboard_data import STEPS, kinetic_energy, thesis_consistency

from webfrontend import plots


def series(kind="thermo", name="thermo", columns=None, x_column="step", meta=None):
    return SimpleNamespace(kind=kind, name=name, x_column=x_column, columns=columns or {}, meta=meta or {})


def labels(spec):
    return [s["label"] for s in spec["series"]]


def test_thermo_quantity_has_units_and_run_legend():
    a = series(columns={"step": STEPS, "ke": kinetic_energy(), "atoms": [12] * len(STEPS)})
    b = series(columns={"step": STEPS, "ke": kinetic_energy(1e-4), "atoms": [12] * len(STEPS)})
    spec = plots.series_plot([("#1 dem-v1", a), ("#2 dem-master", b)], "ke")
    assert (spec["title"], spec["xlabel"], spec["ylabel"]) == ("thermo: ke", "step [1]", "ke [J]")
    assert labels(spec) == ["#1 dem-v1", "#2 dem-master"]
    # the second curve is dashed: identical curves stay visible in an overlay
    assert [s["dash"] for s in spec["series"]] == [False, True]
    assert spec["x"] == STEPS and spec["series"][1]["values"][-1] == kinetic_energy(1e-4)[-1]
    assert plots.quantities(a) == ["ke", "atoms"]
    json.dumps(spec, allow_nan=False)


def test_vtk_ke_without_masses_is_per_unit_mass():
    # harness.execution.postprocess.vtk_aggregates: ke equals ke_per_mass (J/kg) when the dumps carry no masses
    no_mass = series(kind="vtk", name="dumps", columns={"step": [0, 1], "ke": [2.0, 1.0], "ke_per_mass": [2.0, 1.0]})
    with_mass = series(kind="vtk", name="dumps", columns={"step": [0, 1], "ke": [0.2, 0.1], "ke_per_mass": [2.0, 1.0]})
    assert plots.series_plot([("#1", no_mass)], "ke")["ylabel"] == "ke [J/kg]"
    assert plots.series_plot([("#1", with_mass)], "ke")["ylabel"] == "ke [J]"
    assert plots.series_plot([("#1", no_mass)], "ke_per_mass")["ylabel"] == "ke_per_mass [J/kg]"


def test_declared_plot_uses_its_title_labels_and_legend():
    torque = series(kind="plot", name="torqueZ", x_column="t",
                    columns={"t": [0.0, 0.1, 0.2], "torqueZ": [0.0, 1.0, 0.5]},
                    meta={"title": "Torque", "xlabel": "time_[s]", "ylabel": "torque_z_[Nm]",
                          "legend": ["torqueZ_(rotor)"]})
    spec = plots.series_plot([("#1", torque)], None)
    assert (spec["title"], spec["xlabel"], spec["ylabel"], labels(spec)) == (
        "Torque", "time [s]", "torque z [Nm]", ["torqueZ (rotor)"])
    assert labels(plots.series_plot([("#1", torque), ("#2", torque)], None)) == [
        "#1, torqueZ (rotor)", "#2, torqueZ (rotor)"]


def test_text_series_are_not_plotted_and_nan_is_a_gap():
    words = series(kind="textfile", name="result.txt", x_column="", columns={"words": ["e", "=", "0.9"]})
    assert plots.quantities(words) == []
    spec = plots.series_plot([("#1", series(columns={"step": [0, 1, 2], "ke": [1.0, float("nan"), float("inf")]}))], "ke")
    assert spec["series"][0]["values"] == [1.0, None, None]
    json.dumps(spec, allow_nan=False)


def test_compared_runs_on_different_steps_share_one_abscissa_and_differences_are_drawn():
    a = series(columns={"step": [0, 10, 20], "ke": [1.0, 2.0, 3.0]})
    b = series(columns={"step": [0, 20, 30], "ke": [1.0, 2.5, 9.0]})
    spec = plots.series_plot([("#1", a), ("#2", b)], "ke")
    assert spec["x"] == [0, 10, 20, 30]
    assert [s["values"] for s in spec["series"]] == [[1.0, 2.0, 3.0, None], [1.0, None, 2.5, 9.0]]
    diff = plots.difference_plot([("#1", a), ("#2", b)], "ke")
    assert diff["x"] == [0, 20] and diff["series"][0]["values"] == [0.0, -0.5]
    assert diff["ylabel"] == "difference of ke [J]" and labels(diff) == ["#2 - #1"]


def test_expectations_are_drawn_with_their_tolerance():
    config = {"expectations": [{"quantity": "thermo.ke", "value": 2.0, "rel_tol": 0.1},
                               {"quantity": "thermo.ke", "at": "max", "upper": 3.0},
                               {"quantity": "other.ke", "value": 1.0}]}
    overlays = plots.expectation_overlays(config, "thermo", "ke")
    spec = plots.series_plot([("#1", series(columns={"step": [0, 1], "ke": [2.0, 2.1]}))], "ke", overlays)
    assert labels(spec)[1:] == ["expected end - tolerance", "expected end + tolerance", "upper bound (max)"]
    assert [s["values"][0] for s in spec["series"][1:]] == [1.8, 2.2, 3.0]
    assert spec["bands"] == [{"upper": 2, "lower": 1, "fill": overlays[0]["fill"]}]
    # an expectation stated for other engines is not drawn on this run's plot
    config["expectations"][0]["engines"] = ["yade"]
    assert len(plots.expectation_overlays(config, "thermo", "ke", "dem")) == 1
    assert len(plots.expectation_overlays(config, "thermo", "ke", "yade")) == 2


def test_bands_are_the_thesis_levels_and_agree_with_the_check():
    from harness.analysis.consistency import score

    ref, run = kinetic_energy(), kinetic_energy(shift=8e-5)
    c, eps, first_bad, level = thesis_consistency(run, ref)
    for lvl in (0.05, 0.10):
        assert 0.1 * plots.band_half_width(lvl, eps) / eps == np.float64(lvl)
    assert plots.epsilon_of(ref, None) == eps
    checked = score(ref, run)
    assert abs(checked.value - c) < 1e-12 and checked.level == level == "inconsistent"

    result = SimpleNamespace(quantity="ke", series_name="thermo", value=c, level=level, epsilon=eps,
                             first_bad_step=float(first_bad))
    overlay, deviation = plots.consistency_plots(result, series(columns={"step": STEPS, "ke": run}),
                                                 series(columns={"step": STEPS, "ke": ref}), "#2 dem-master",
                                                 "#1 dem-v1")
    assert overlay["title"] == f"thermo: ke  (C = {c:.4f}, inconsistent)"
    assert (overlay["xlabel"], overlay["ylabel"]) == ("step [1]", "ke [J]")
    assert [b["label"] for b in overlay["bands"]] == ["10 % band (good)", "5 % band (perfect)"]
    assert labels(overlay)[-2:] == ["reference: #1 dem-v1", "#2 dem-master"]
    assert overlay["markers"] == [{"x": 1000.0, "label": "first out of band: 1000", "color": plots.MARKER_COLOR}]
    # the 10 % band's upper edge lies eps above the reference at every step, the 5 % one eps/2
    wide = overlay["series"][overlay["bands"][0]["upper"]]["values"]
    narrow = overlay["series"][overlay["bands"][1]["upper"]]["values"]
    for r, w, n in zip(ref, wide, narrow):
        assert abs(w - (r + eps)) < 1e-15 and abs(n - (r + eps / 2)) < 1e-15
    # the deviation leaves the 10 % band exactly where the check says
    dev = deviation["series"][-1]["values"]
    outside = [s for s, d in zip(STEPS, dev) if abs(d) > eps]
    assert outside[0] == first_bad == 1000
    assert deviation["ylabel"] == "x - x_ref [J]"


def test_history_bounds_the_consistency_axis_and_keeps_true_values_on_hover():
    lines = {"serial": {"c": [0.99, -8186.0, 0.97], "stepping": [1.0, 1.0, 2.0], "wall": [3.0, 3.1, 4.0]}}
    c_plot, time_plot, startup_plot = plots.history_plots(["aaaaaaa", "bbbbbbb", "ccccccc"], lines,
                                            [{"index": 2, "label": "ccccccc serial: slower"}], "case on dem")
    assert c_plot["xticks"] == ["aaaaaaa", "bbbbbbb", "ccccccc"] and c_plot["x"] == [0, 1, 2]
    line = c_plot["series"][0]
    assert line["values"] == [0.99, plots.C_AXIS_FLOOR, 0.97] and line["hover"] == [0.99, -8186.0, 0.97]
    assert c_plot["ylimits"][0] > -1 and c_plot["ylimits"][1] > 1
    # stepping time alone on a log axis; start-up (wall - stepping: 2 s, 2.1 s, 2 s) on its own
    assert labels(time_plot) == ["serial stepping time"] and time_plot["ylog"]
    assert time_plot["markers"][0]["x"] == 2 and time_plot["ylabel"] == "stepping time [s] (log)"
    assert labels(startup_plot) == ["serial start-up"] and startup_plot["ylog"]
    assert startup_plot["series"][0]["values"] == pytest.approx([2.0, 2.1, 2.0])
    unclipped = plots.history_plots(["a"], {"s": {"c": [0.9], "stepping": [1.0], "wall": [1.0]}}, [], "t")[0]
    assert unclipped["ylimits"] is None


def test_sweep_is_log_log_with_the_observed_order():
    import pandas as pd

    dt = [4e-4, 2e-4, 1e-4]
    table = pd.DataFrame({"value": dt, "run_time": [1.0, 2.0, 4.0], "quantity": [0.0] * 3,
                          "error": [5e4 * d ** 2 for d in dt], "state": ["post_processed"] * 3})
    spec = {"variable": "DT", "error": {"quantity": "thermo.z", "exact": 1.0}}
    cost, conv = plots.sweep_plots(table, spec, "dem: accuracy/oscillator/dt")
    assert cost["xlog"] and cost["ylog"] and cost["x"] == [1.0, 2.0, 4.0]
    assert conv["x"] == sorted(dt) and labels(conv) == ["observed order 2.00", "order 2 (reference slope)"]
