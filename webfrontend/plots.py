"""Plots of the dashboard as data: JSON the browser draws (webfrontend/static/webfrontend/plots.js, uPlot).

The server says what is drawn - abscissa, curves, bands, markers, axis labels with units, axis limits - and
the browser draws it with zoom, values on hover and series switched on and off in the legend. No image is
drawn per request, so no plotting state is shared between the threads of a server (pyplot's global state
gave HTTP 500 under parallel image requests).

Plot kinds (thesis 4.4.1, 4.4.2, 4.6): a quantity of a data series over its abscissa for one or many runs,
the difference of compared runs to the first one, a declared plot with its own title, labels and legend, a
version consistency plot with the 5 % and 10 % acceptance bands around the reference trajectory (and the
deviation from it against the bands' half widths), the history of a test case over commits, and a sweep's
error against run time and against the swept value (log-log).

A plot is a dict::

    {"title", "xlabel", "ylabel", "x": [...], "series": [{"label", "values", "color", "dash", "points",
     "hover" (true values where ``values`` are clipped), "show"}], "bands": [{"upper": i, "lower": i,
     "fill"}], "markers": [{"x", "label", "color"}], "xlog", "ylog", "ylimits": [lo, hi] or None,
     "xticks": [labels] or None (categorical abscissa: x are indices)}

Non-finite numbers become None (JSON has no NaN): a gap in the curve.
"""
from __future__ import annotations

import math

from harness.analysis.consistency import AXIS_COLUMNS, axis_asked
from harness.config.acceptance import applies
from harness.config.sweep import observed_order

#: units of the thermo quantities every test case writes (thesis 4.4.1) and common abscissae;
#: a series' own ``meta["units"]`` wins
DEFAULT_UNITS = {
    "step": "1", "atoms": "1", "natoms": "1", "ke": "J", "kineng": "J", "rke": "J", "c_rke": "J",
    "time": "s", "t": "s", "dt": "s", "cpu": "s", "pe": "J", "etotal": "J", "press": "Pa",
    # aggregates of VTK particle dumps (harness/execution/postprocess.py vtk_aggregates)
    "particles": "1", "ke_per_mass": "J/kg", "vx_mean": "m/s", "vy_mean": "m/s", "vz_mean": "m/s",
    "x_min": "m", "x_max": "m", "y_min": "m", "y_max": "m", "z_min": "m", "z_max": "m",
}
#: the consistency levels (thesis 4.4.1): Delta_k below 5 % is perfect, below 10 % good; widest first, so
#: the narrow band is drawn over the wide one
LEVELS = (("10 % band (good)", 0.10, "rgba(246, 180, 90, 0.35)"), ("5 % band (perfect)", 0.05,
                                                                  "rgba(90, 180, 90, 0.35)"))
#: curve colours, told apart also by people with the common colour-vision deficiencies (Okabe-Ito)
PALETTE = ("#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#000000", "#f0e442")
REFERENCE_COLOR = "#222222"
MARKER_COLOR = "#c0392b"
#: lowest C a history axis shows: C = 1 - max Delta_k has no lower bound (a run far off scores -8186), and
#: one such value would flatten every other point against 1; lower values are drawn at the bound and their
#: true value shown on hover
C_AXIS_FLOOR = -0.5


def finite_or_none(value):
    """A number JSON can carry: floats that are NaN or infinite become None (a gap)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def numeric(values) -> list[float]:
    """Values as floats (None and non-numbers become NaN, so a gap shows instead of an error)."""
    out = []
    for v in values or []:
        try:
            out.append(float(v))
        except (TypeError, ValueError):
            out.append(math.nan)
    return out


def _json(values) -> list:
    return [finite_or_none(v) for v in values]


def _vtk_ke_per_mass(series) -> bool:
    """Whether a VTK dump series' ``ke`` is per unit mass: harness.execution.postprocess.vtk_aggregates gives ``ke``
    in J only when the dumps carry masses (or radii and a density), otherwise the same numbers as its
    ``ke_per_mass`` column, in J/kg."""
    cols = series.columns if isinstance(series.columns, dict) else {}
    return series.kind == "vtk" and cols.get("ke") is not None and cols.get("ke") == cols.get("ke_per_mass")


def unit_of(series, column: str) -> str | None:
    units = (series.meta or {}).get("units") or {}
    if column in units:
        return units[column]
    if column == "ke" and _vtk_ke_per_mass(series):
        return "J/kg"
    return DEFAULT_UNITS.get(column.lower())


def label_of(series, column: str) -> str:
    """Axis label "name [unit]" (unit 1 = dimensionless)."""
    unit = unit_of(series, column)
    return f"{column} [{unit}]" if unit else column


def _declared_label(text: str) -> str:
    # run.config labels use underscores for spaces, as in the thesis' "time_[s]" (listing 4.11)
    return text.replace("_", " ")


def quantities(series, consistency: dict | None = None) -> list[str]:
    """Plottable columns of a series: numeric lists other than the abscissa, in the order the series had when
    it was read (``meta["order"]``: PostgreSQL's jsonb keeps no key order), else in stored order. A thermo
    axis column (step, time: harness.analysis.consistency.AXIS_COLUMNS) is left out unless the run configuration's
    ``consistency`` names it, as the check does."""
    cols = series.columns if isinstance(series.columns, dict) else {}
    order = (series.meta or {}).get("order")
    names = [n for n in order if n in cols] + [n for n in cols if n not in order] if isinstance(order, list) \
        else list(cols)
    return [name for name in names
            if name != series.x_column and isinstance(cols[name], list) and cols[name]
            and not (series.kind == "thermo" and name.lower() in AXIS_COLUMNS
                     and not axis_asked(consistency, series.name, name))
            and all(isinstance(v, (int, float)) or v is None for v in cols[name][:50])]


def abscissa(series) -> tuple[list[float], str]:
    """x values and axis label; without an abscissa column the sample index is used."""
    cols = series.columns if isinstance(series.columns, dict) else {}
    if series.x_column and series.x_column in cols:
        if series.kind == "plot" and (series.meta or {}).get("xlabel"):
            return numeric(cols[series.x_column]), _declared_label(series.meta["xlabel"])
        return numeric(cols[series.x_column]), label_of(series, series.x_column)
    length = max((len(v) for v in cols.values() if isinstance(v, list)), default=0)
    return [float(i) for i in range(length)], "sample [1]"


def _points(series, column: str) -> list[tuple[float, float]]:
    """(x, y) of one column, in order of x, points without a finite x left out."""
    x, _ = abscissa(series)
    y = numeric((series.columns or {}).get(column))
    pairs = [(a, b) for a, b in zip(x, y) if math.isfinite(a)]
    return sorted(pairs, key=lambda p: p[0])


def _aligned(curves: list[list[tuple[float, float]]]) -> tuple[list[float], list[list]]:
    """One abscissa for several curves (the union of their x values) and each curve's values on it (None
    where a curve has no point): uPlot draws all series of a plot over one x array."""
    if len(curves) == 1:
        return [p[0] for p in curves[0]], [[p[1] for p in curves[0]]]
    xs = sorted({p[0] for curve in curves for p in curve})
    out = []
    for curve in curves:
        by_x = dict(curve)
        out.append([by_x.get(x) for x in xs])
    return xs, out


def plot(title: str, xlabel: str, ylabel: str, x, series: list[dict], **extra) -> dict:
    """A plot dict (see the module docstring) with JSON-safe numbers."""
    for s in series:
        s["values"] = _json(s["values"])
        if "hover" in s:
            s["hover"] = _json(s["hover"])
    return {"title": title, "xlabel": xlabel, "ylabel": ylabel, "x": _json(x), "series": series,
            "bands": extra.get("bands", []), "markers": extra.get("markers", []), "xlog": extra.get("xlog", False),
            "ylog": extra.get("ylog", False), "ylimits": extra.get("ylimits"), "xticks": extra.get("xticks")}


def _column_names(first, quantity: str | None) -> tuple[list[str], dict]:
    """Columns drawn for a quantity (a declared plot without one: all its columns) and their legend names."""
    meta = first.meta or {}
    all_columns = quantities(first)
    columns = [quantity] if quantity else all_columns
    legend = meta.get("legend") or []
    names = {}
    for column in columns:
        names[column] = column
        if first.kind == "plot" and column in all_columns and all_columns.index(column) < len(legend):
            names[column] = _declared_label(legend[all_columns.index(column)])
    return columns, names


def _titles(first, quantity, columns) -> tuple[str, str]:
    meta = first.meta or {}
    declared = first.kind == "plot"
    title = (meta.get("title") if declared else None) or f"{first.name}: {quantity or ', '.join(columns)}"
    if declared and meta.get("ylabel"):
        ylabel = _declared_label(meta["ylabel"])
    else:
        ylabel = label_of(first, columns[0]) if len(columns) == 1 else "value"
    return title, ylabel


def series_plot(curves: list[tuple[str, object]], quantity: str | None, overlays: list[dict] | None = None
                ) -> dict:
    """One quantity (or, for a declared plot and ``quantity=None``, all its columns) for one or more runs.

    ``curves`` is ``[(run label, Series)]``; with several runs each gets its own line (thesis 4.6.2: plots
    of all compared runs overlaid; the second run dashed so that identical curves stay visible).
    ``overlays`` are expectation lines and bands (``expectation_overlays``) drawn over the data.
    """
    first = curves[0][1]
    columns, names = _column_names(first, quantity)
    _, xlabel = abscissa(first)
    labels, data = [], []
    for label, series in curves:
        for column in columns:
            parts = [p for p in (label if len(curves) > 1 else "",
                                 names[column] if len(columns) > 1 or first.kind == "plot" else "") if p]
            labels.append(", ".join(parts) or column)
            data.append(_points(series, column))
    x, values = _aligned(data)
    series = [{"label": label, "values": v, "color": PALETTE[i % len(PALETTE)], "dash": i % 2 == 1}
              for i, (label, v) in enumerate(zip(labels, values))]
    bands = []
    add_overlays(series, bands, len(x), overlays)
    title, ylabel = _titles(first, quantity, columns)
    return plot(title, xlabel, ylabel, x, series, bands=bands)


def add_overlays(series: list[dict], bands: list[dict], length: int, overlays: list[dict] | None) -> None:
    """Expectation lines and bands (``expectation_overlays``) appended to a plot's series and bands."""
    for overlay in overlays or []:
        base = len(series)
        for line in overlay["lines"]:
            series.append({"label": line["label"], "values": [line["y"]] * length, "color": overlay["color"],
                           "dash": True, "width": 1})
        if overlay.get("band") and len(overlay["lines"]) == 2:
            bands.append({"upper": base + 1, "lower": base, "fill": overlay["fill"]})


def difference_plot(curves: list[tuple[str, object]], quantity: str) -> dict | None:
    """Each further run minus the first on the abscissa values both have: where identical curves hide each
    other in an overlay, their difference is a flat zero (None: fewer than two runs with the quantity)."""
    first_label, first = curves[0]
    base = dict(_points(first, quantity))
    others = [(label, _points(s, quantity)) for label, s in curves[1:]]
    others = [(label, [(x, y - base[x]) for x, y in pts if x in base]) for label, pts in others]
    others = [(label, pts) for label, pts in others if pts]
    if not base or not others:
        return None
    x, values = _aligned([pts for _, pts in others])
    series = [{"label": f"{label} - {first_label}", "values": v, "color": PALETTE[(i + 1) % len(PALETTE)]}
              for i, ((label, _), v) in enumerate(zip(others, values))]
    _, xlabel = abscissa(first)
    unit = unit_of(first, quantity)
    return plot(f"{first.name}: {quantity}, difference to {first_label}", xlabel,
                f"difference of {quantity}" + (f" [{unit}]" if unit else ""), x, series)


def expectation_overlays(config: dict, series_name: str, column: str, engine: str | None = None) -> list[dict]:
    """Lines of the run configuration's expectations on ``SERIES.COLUMN`` (harness/config/acceptance.py): the
    expected value with its tolerance band, or the lower/upper bounds. The bounds apply to the reduced
    value (``at``: end, start, min, max, mean), which the legend names. Only the expectations that hold for
    the run's engine adapter ``engine`` (``acceptance.applies``; None: all)."""
    out = []
    for spec in (config or {}).get("expectations") or []:
        if not isinstance(spec, dict) or spec.get("quantity") != f"{series_name}.{column}":
            continue
        if not applies(spec, engine):
            continue
        at = spec.get("at", "end")
        try:
            if "value" in spec:
                value = float(spec["value"])
                half = max(float(spec.get("rel_tol", 0.0)) * abs(value), float(spec.get("abs_tol", 0.0)))
                lines = [{"label": f"expected {at} - tolerance", "y": value - half},
                         {"label": f"expected {at} + tolerance", "y": value + half}] if half else \
                        [{"label": f"expected {at} = {value:.6g}", "y": value}]
                out.append({"lines": lines, "band": bool(half), "color": "#7b3294",
                            "fill": "rgba(123, 50, 148, 0.15)"})
            else:
                lines = [{"label": f"{bound} bound ({at})", "y": float(spec[bound])}
                         for bound in ("lower", "upper") if bound in spec]
                out.append({"lines": lines, "band": len(lines) == 2, "color": "#7b3294",
                            "fill": "rgba(123, 50, 148, 0.10)"})
        except (TypeError, ValueError):
            continue  # a malformed expectation fails the run's validation; nothing to draw here
    return out


def epsilon_of(reference_values: list[float], stored: float | None) -> float:
    """Global tolerance of thesis eq. 4.2, eps = 0.1 (max x_ref - min x_ref) / 2, unless stored by the check."""
    if stored is not None:
        return stored
    finite = [v for v in reference_values if math.isfinite(v)]
    return 0.1 * (max(finite) - min(finite)) / 2 if finite else 0.0


def band_half_width(level: float, eps: float) -> float:
    """|x - x_ref| below which Delta_k = 0.1 |x - x_ref| / eps (thesis eq. 4.3) stays below ``level``."""
    return level * eps / 0.1


def consistency_plots(result, run_series, reference_series, run_label: str, reference_label: str) -> list[dict]:
    """Thesis figure 4.11: a run's trajectory over its reference with the 5 % and 10 % acceptance bands, and
    the deviation x - x_ref against the bands' half widths (what the overlay cannot show when the curves
    lie on each other).

    ``result`` is a ConsistencyResult (or harness.analysis.consistency.QuantityResult): quantity, C, level, eps,
    first step out of band; the series hold the data.
    """
    quantity = result.quantity
    ref = _points(reference_series, quantity)
    run = _points(run_series, quantity) if run_series is not None else []
    eps = epsilon_of([y for _, y in ref], result.epsilon)
    x, (y_ref, y_run) = _aligned([ref, run]) if run else ([p[0] for p in ref], [[p[1] for p in ref], []])
    series, bands = [], []
    for name, level, fill in LEVELS:
        half = band_half_width(level, eps)
        lower = [None if y is None else y - half for y in y_ref]
        upper = [None if y is None else y + half for y in y_ref]
        series += [{"label": f"{name} lower", "values": lower, "color": "rgba(0,0,0,0)", "band_edge": True},
                   {"label": f"{name} upper", "values": upper, "color": "rgba(0,0,0,0)", "band_edge": True}]
        bands.append({"upper": len(series) - 1, "lower": len(series) - 2, "fill": fill, "label": name})
    series.append({"label": f"reference: {reference_label}", "values": y_ref, "color": REFERENCE_COLOR})
    if run:
        series.append({"label": run_label, "values": y_run, "color": PALETTE[0], "dash": True})
    markers = [{"x": result.first_bad_step, "label": f"first out of band: {result.first_bad_step:g}",
                "color": MARKER_COLOR}] if result.first_bad_step is not None else []
    c_text = "n/a" if result.value is None else f"{result.value:.4f}"
    _, xlabel = abscissa(reference_series)
    title = f"{result.series_name}: {quantity}  (C = {c_text}, {result.level})"
    out = [plot(title, xlabel, label_of(reference_series, quantity), x, series, bands=bands, markers=markers)]
    if run:
        common = [(a, r, b) for a, r, b in zip(x, y_ref, y_run) if r is not None and b is not None]
        dx = [a for a, _, _ in common]
        deviation = [b - r for _, r, b in common]
        dev_series, dev_bands = [], []
        for name, level, fill in LEVELS:
            half = band_half_width(level, eps)
            dev_series += [{"label": f"{name} lower", "values": [-half] * len(dx), "color": "rgba(0,0,0,0)",
                            "band_edge": True},
                           {"label": f"{name} upper", "values": [half] * len(dx), "color": "rgba(0,0,0,0)",
                            "band_edge": True}]
            dev_bands.append({"upper": len(dev_series) - 1, "lower": len(dev_series) - 2, "fill": fill,
                              "label": name})
        dev_series.append({"label": f"{run_label} - reference", "values": deviation, "color": PALETTE[0]})
        unit = unit_of(reference_series, quantity)
        out.append(plot(f"{result.series_name}: {quantity}, deviation from the reference (eps = {eps:.4g})",
                        xlabel, "x - x_ref" + (f" [{unit}]" if unit else ""), dx, dev_series, bands=dev_bands,
                        markers=markers))
    return out


def clipped_c(values: list[float | None]) -> tuple[list[float | None], list[float | None], list[float] | None]:
    """(values drawn, true values for hover, axis limits) of consistency scores: values below
    ``C_AXIS_FLOOR`` are drawn at the floor (limits then fixed to [floor, 1.02])."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if not finite or min(finite) >= C_AXIS_FLOOR:
        return values, values, None
    drawn = [None if v is None else max(v, C_AXIS_FLOOR) for v in values]
    return drawn, values, [C_AXIS_FLOOR - 0.05, 1.02]


def history_plots(labels: list[str], lines: dict[str, dict], changes: list[dict], title: str) -> list[dict]:
    """C, stepping time (log axis) and start-up (wall - stepping time: process start, kernel compilation,
    output; log axis) of a test case's run configurations over the commits of a target.

    ``labels`` are the commits oldest first (the abscissa is their index); ``lines`` maps a run
    configuration name to ``{"c": [...], "stepping": [...], "wall": [...]}`` (None where it has no run);
    ``changes`` are ``{"index", "label"}`` of the commits harness.analysis.regressions marked.
    """
    markers = [{"x": c["index"], "label": c["label"], "color": MARKER_COLOR} for c in changes]
    x = list(range(len(labels)))
    c_series, t_series, o_series = [], [], []
    limits = None
    for i, (name, line) in enumerate(sorted(lines.items())):
        drawn, true, clip = clipped_c(line["c"])
        limits = clip or limits
        c_series.append({"label": f"{name} lowest C", "values": drawn, "hover": true,
                         "color": PALETTE[i % len(PALETTE)], "points": True})
        t_series.append({"label": f"{name} stepping time", "values": positive(line["stepping"]),
                         "color": PALETTE[i % len(PALETTE)], "points": True})
        overhead = [None if w is None or t is None else w - t for w, t in zip(line["wall"], line["stepping"])]
        o_series.append({"label": f"{name} start-up", "values": positive(overhead),
                         "color": PALETTE[i % len(PALETTE)], "dash": True, "points": True})
    c_series += [{"label": "C = 0.95 (perfect)", "values": [0.95] * len(x), "color": "#2e8b57", "dash": True,
                  "width": 1},
                 {"label": "C = 0.90 (good)", "values": [0.90] * len(x), "color": "#d68910", "dash": True,
                  "width": 1}]
    # speed on its own log axis: a 5 ms test and a 5 s one both show their changes; start-up (process start,
    # kernel compilation on a new build, output) apart, so that 50 s of compilation does not swamp it
    out = [plot(f"{title}: lowest consistency C per commit", "commit (oldest first)", "lowest C [1]", x,
                c_series, markers=markers, xticks=labels, ylimits=limits)]
    # a log axis without a single value draws nothing: such a plot is left out (no engine reported a time)
    if any(v is not None for s in t_series for v in s["values"]):
        out.append(plot(f"{title}: stepping time per commit", "commit (oldest first)", "stepping time [s] (log)",
                        x, t_series, markers=markers, xticks=labels, ylog=True))
    if any(v is not None for s in o_series for v in s["values"]):
        out.append(plot(f"{title}: start-up per commit (wall time - stepping time)", "commit (oldest first)",
                        "start-up [s] (log)", x, o_series, xticks=labels, ylog=True))
    return out


def positive(values: list) -> list:
    """Values for a log axis: None where a value is missing or not above 0."""
    return [v if v is not None and v > 0 else None for v in values]


def sweep_plots(table, spec: dict, title: str) -> list[dict]:
    """A sweep (harness.config.sweep.SweepResult.table, its spec) as two log-log plots: error against run time (what
    accuracy costs) and error against the swept value with an order-2 reference slope."""
    variable, quantity = spec["variable"], spec["error"]["quantity"]
    rows = [r for r in table.itertuples() if finite_or_none(r.error) and r.error > 0]
    by_time = sorted((r for r in rows if finite_or_none(r.run_time) and r.run_time > 0), key=lambda r: r.run_time)
    cost = plot(f"{title}: what accuracy costs in time", "run time [s] (engine time stepping)",
                f"error of {quantity}", [r.run_time for r in by_time],
                [{"label": f"error ({variable} = " + ", ".join(f"{r.value:g}" for r in by_time) + ")",
                  "values": [r.error for r in by_time], "color": PALETTE[0], "points": True}],
                xlog=True, ylog=True)
    by_value = sorted(rows, key=lambda r: r.value)
    order = observed_order([r.value for r in by_value], [r.error for r in by_value])
    series = [{"label": f"observed order {order:.2f}" if order is not None else "error",
               "values": [r.error for r in by_value], "color": PALETTE[1], "points": True}]
    if order is not None and by_value:
        x0, e0 = by_value[0].value, by_value[0].error
        series.append({"label": "order 2 (reference slope)", "values": [e0 * (r.value / x0) ** 2 for r in by_value],
                       "color": "#888888", "dash": True})
    conv = plot(f"{title}: convergence", variable, f"error of {quantity}", [r.value for r in by_value], series,
                xlog=True, ylog=True)
    return [cost, conv]
