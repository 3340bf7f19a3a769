"""Plots: titles, axis labels with units, legends, and acceptance bands that agree with the check."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from dashboard_data import STEPS, kinetic_energy, thesis_consistency
from webfrontend import plots


def series(kind="thermo", name="thermo", columns=None, x_column="step", meta=None):
    return SimpleNamespace(kind=kind, name=name, x_column=x_column, columns=columns or {}, meta=meta or {})


def texts(fig):
    ax = fig.axes[0]
    return ax.get_title(), ax.get_xlabel(), ax.get_ylabel(), [t.get_text() for t in fig.legends[0].get_texts()]


def test_thermo_quantity_has_units_and_run_legend():
    a = series(columns={"step": STEPS, "ke": kinetic_energy(), "atoms": [12] * len(STEPS)})
    b = series(columns={"step": STEPS, "ke": kinetic_energy(1e-4), "atoms": [12] * len(STEPS)})
    title, xlabel, ylabel, legend = texts(plots.series_figure([("#1 dem-v1", a), ("#2 dem-master", b)], "ke"))
    assert (title, xlabel, ylabel) == ("thermo: ke", "step [1]", "ke [J]")
    assert legend == ["#1 dem-v1", "#2 dem-master"]
    assert plots.quantities(a) == ["ke", "atoms"]
    assert plots.png(plots.series_figure([("#1", a)], "ke")).startswith(b"\x89PNG")


def test_declared_plot_uses_its_title_labels_and_legend():
    torque = series(kind="plot", name="torqueZ", x_column="t",
                    columns={"t": [0.0, 0.1, 0.2], "torqueZ": [0.0, 1.0, 0.5]},
                    meta={"title": "Torque", "xlabel": "time_[s]", "ylabel": "torque_z_[Nm]",
                          "legend": ["torqueZ_(rotor)"]})
    assert texts(plots.series_figure([("#1", torque)], None)) == (
        "Torque", "time [s]", "torque z [Nm]", ["torqueZ (rotor)"])
    fig = plots.series_figure([("#1", torque), ("#2", torque)], None)
    assert texts(fig)[3] == ["#1, torqueZ (rotor)", "#2, torqueZ (rotor)"]


def test_text_series_are_not_plotted():
    words = series(kind="textfile", name="result.txt", x_column="", columns={"words": ["e", "=", "0.9"]})
    assert plots.quantities(words) == []


def test_bands_are_the_thesis_levels_and_agree_with_the_check():
    from harness.consistency import score

    ref, run = kinetic_energy(), kinetic_energy(shift=8e-5)
    c, eps, first_bad, level = thesis_consistency(run, ref)
    # Delta_k = 0.1 |x - x_ref| / eps equals the level exactly at the band edge (thesis eq. 4.3)
    for lvl in (0.05, 0.10):
        assert 0.1 * plots.band_half_width(lvl, eps) / eps == np.float64(lvl)
    assert plots.epsilon_of(ref, None) == eps
    checked = score(ref, run)
    assert abs(checked.value - c) < 1e-12 and checked.level == level == "inconsistent"
    outside = [s for s, x, r in zip(STEPS, run, ref) if abs(x - r) > plots.band_half_width(0.10, eps)]
    assert STEPS[checked.first_bad] == outside[0] == first_bad == 1000

    result = SimpleNamespace(quantity="ke", series_name="thermo", value=c, level=level, epsilon=eps,
                             first_bad_step=float(first_bad))
    fig = plots.consistency_figure(result, series(columns={"step": STEPS, "ke": run}),
                                   series(columns={"step": STEPS, "ke": ref}), "#2 dem-master", "#1 dem-v1")
    title, xlabel, ylabel, legend = texts(fig)
    assert title == f"thermo: ke  (C = {c:.4f}, inconsistent)"
    assert (xlabel, ylabel) == ("step [1]", "ke [J]")
    assert legend == ["10 % band (good)", "5 % band (perfect)", "reference: #1 dem-v1", "#2 dem-master",
                      "first out of band: 1000"]
    # the 10 % band's upper edge lies eps above the reference at every step
    wide, narrow = fig.axes[0].collections[:2]
    top = wide.get_paths()[0].vertices
    upper = {x: y for x, y in top if y >= np.interp(x, STEPS, ref)}
    for step, r in zip(STEPS, ref):
        assert abs(upper[step] - (r + eps)) < 1e-15
    assert narrow.get_paths()[0].vertices[:, 1].max() < top[:, 1].max()


def test_history_has_revisions_in_order():
    def run(revision, commit, c, t):
        return SimpleNamespace(build=SimpleNamespace(revision=revision, commit=commit), name="serial",
                               consistency_min=c, wall_time=t)

    fig = plots.history_figure([run("v1", "a" * 40, 1.0, 2.0), run("HEAD", "b" * 40, 0.8, 1.0)],
                               "contact_models/hertz/impact", "dem-master")
    ax_c, ax_t = fig.axes
    assert [t.get_text() for t in ax_t.get_xticklabels()] == ["v1 (aaaaaaa)", "bbbbbbb"]
    assert (ax_c.get_ylabel(), ax_t.get_ylabel()) == ("lowest C [1]", "wall time [s]")
    assert fig.get_suptitle() == "contact_models/hertz/impact on dem-master"
    assert ax_c.get_title() == "lowest consistency C per revision"
    assert list(ax_t.lines[0].get_ydata()) == [2.0, 1.0]
