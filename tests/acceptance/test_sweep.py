"""Sweep expansion, error table and observed convergence order (harness.config.sweep)."""
import math

import numpy as np
import pandas as pd

from harness.config import sweep as sw
from harness.config.check import validate as validate_schema
from harness.config.runconfig import RunConfigEntry
from harness.config.jsonfile import json_path


def validate(entry: dict) -> list[str]:
    """The problems of a run configuration's sweep block (the schema's and the rules between its fields), as
    ``PATH: message`` with the path inside the entry."""
    found = validate_schema(RunConfigEntry, {"name": "r", "script": "s.json", **entry})[1] + sw.problems(entry)
    return [f"{json_path(*p.path)[2:]}: {p.message}" for p in found]


SWEEP = {"variable": "DTF", "values": [0.4, 0.2, 0.1], "error": {"quantity": "thermo.ke", "exact": 1.0}}


def test_expand_gives_one_run_per_value_with_the_variable_set():
    entry = {"name": "bounce", "script": "in.json", "variables": {"E": 0.9}, "sweep": SWEEP}
    points = sw.expand(entry)
    assert [p["name"] for p in points] == ["bounce@DTF=0.4", "bounce@DTF=0.2", "bounce@DTF=0.1"]
    assert [p["variables"]["DTF"] for p in points] == [0.4, 0.2, 0.1]
    assert all(p["variables"]["E"] == 0.9 and "sweep" not in p for p in points)
    assert "sweep" in entry  # the original is untouched
    assert sw.expand({"name": "plain"}) == [{"name": "plain"}]
    companions = sw.expand({"name": "b", "sweep": {**SWEEP, "with": {"STEPS": [10, 20, 40]}}})
    assert [p["variables"]["STEPS"] for p in companions] == [10, 20, 40]
    assert "sweep.with.STEPS" in validate({"name": "b", "sweep": {**SWEEP, "with": {"STEPS": [1]}}})[0]


def test_validate_reports_paths():
    assert validate({"sweep": SWEEP}) == []
    errors = "\n".join(validate({"sweep": {"variable": "", "values": [1, -1], "error": {"quantity": "ke"}}}))
    assert "sweep.variable" in errors and "sweep.values[1]: must be a number > 0" in errors
    assert "sweep.error.quantity" in errors


def test_second_order_error_gives_order_two():
    dts = np.array([0.4, 0.2, 0.1, 0.05])
    points = [sw.SweepPoint(dt, 1.0 / dt, 1.0 + 3.0 * dt**2) for dt in dts]
    table = sw.sweep_table(SWEEP, points)
    assert list(table["value"]) == [0.4, 0.2, 0.1, 0.05]
    np.testing.assert_allclose(table["error"], 3.0 * dts**2)
    assert abs(sw.observed_order(table["value"], table["error"]) - 2.0) < 1e-9


def test_error_against_the_finest_run_when_no_exact_value():
    spec = {"variable": "N", "values": [10, 20, 40], "finest": "max", "error": {"quantity": "thermo.ke"}}
    table = sw.sweep_table(spec, [sw.SweepPoint(40, 4.0, 1.0), sw.SweepPoint(10, 1.0, 1.5),
                                  sw.SweepPoint(20, 2.0, 1.1)])
    assert list(table["value"]) == [10, 20, 40]
    assert table["error"].iloc[0] == 0.5 and abs(table["error"].iloc[1] - 0.1) < 1e-12
    assert math.isnan(table["error"].iloc[2])


def test_measure_and_plot(tmp_path):
    data = {"thermo": pd.DataFrame({"step": [0, 1], "ke": [2.0, 3.0]})}
    assert sw.measure({"quantity": "thermo.ke", "at": "max"}, data) == 3.0
    assert sw.measure({"quantity": "thermo.pe"}, data) is None
    table = sw.sweep_table(SWEEP, [sw.SweepPoint(v, 1 / v, 1 + v**2) for v in SWEEP["values"]])
    out = tmp_path / "sweep.png"
    sw.plot(table, SWEEP, "test", out)
    assert out.stat().st_size > 10_000
