"""Server-side plots of the dashboard (matplotlib, Agg backend, object API: safe in threaded servers).

Plot kinds (thesis 4.4.1, 4.4.2, 4.6): a quantity of a data series over its abscissa for one or many runs,
a declared plot with its own title, labels and legend, a version consistency plot with the 5 % and 10 %
acceptance bands around the reference trajectory, and the history of a test case over revisions.
"""
from __future__ import annotations

import io
import math

import matplotlib

matplotlib.use("Agg")
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

#: units of the thermo quantities every test case writes (thesis 4.4.1) and common abscissae;
#: a series' own ``meta["units"]`` wins
DEFAULT_UNITS = {
    "step": "1", "atoms": "1", "natoms": "1", "ke": "J", "kineng": "J", "rke": "J", "c_rke": "J",
    "time": "s", "t": "s", "dt": "s", "cpu": "s", "pe": "J", "etotal": "J", "press": "Pa",
    # aggregates of VTK particle dumps (harness/postprocess.py)
    "particles": "1", "ke_per_mass": "J/kg", "vx_mean": "m/s", "vy_mean": "m/s", "vz_mean": "m/s",
    "x_min": "m", "x_max": "m", "y_min": "m", "y_max": "m", "z_min": "m", "z_max": "m",
}
#: the consistency levels (thesis 4.4.1): Delta_k below 5 % is perfect, below 10 % good
LEVELS = (("10 % band (good)", 0.10, "#f6d8a8"), ("5 % band (perfect)", 0.05, "#b9e3b0"))
FIGSIZE = (6.4, 4.2)
DPI = 100


def new_figure(size=FIGSIZE) -> Figure:
    # constrained layout keeps the legend below the axes, where it hides no data
    return Figure(figsize=size, dpi=DPI, layout="constrained")


def legend_below(fig: Figure, ax) -> None:
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=2 if len(labels) > 1 else 1,
                   fontsize="small", frameon=False)


def png(fig: Figure) -> bytes:
    """The figure as PNG bytes."""
    buffer = io.BytesIO()
    FigureCanvasAgg(fig).print_png(buffer)
    return buffer.getvalue()


def unit_of(series, column: str) -> str | None:
    units = (series.meta or {}).get("units") or {}
    return units.get(column) or DEFAULT_UNITS.get(column.lower())


def label_of(series, column: str) -> str:
    """Axis label "name [unit]" (unit 1 = dimensionless)."""
    unit = unit_of(series, column)
    return f"{column} [{unit}]" if unit else column


def _declared_label(text: str) -> str:
    # run.config labels use underscores for spaces, as in the thesis' "time_[s]" (listing 4.11)
    return text.replace("_", " ")


def numeric(values) -> list[float]:
    """Values as floats (None and non-numbers become NaN, so a gap shows instead of an error)."""
    out = []
    for v in values or []:
        try:
            out.append(float(v))
        except (TypeError, ValueError):
            out.append(math.nan)
    return out


def quantities(series) -> list[str]:
    """Plottable columns of a series: numeric lists other than the abscissa, in stored order."""
    cols = series.columns if isinstance(series.columns, dict) else {}
    return [name for name, values in cols.items()
            if name != series.x_column and isinstance(values, list) and values
            and all(isinstance(v, (int, float)) or v is None for v in values[:50])]


def abscissa(series) -> tuple[list[float], str]:
    """x values and axis label; without an abscissa column the sample index is used."""
    cols = series.columns if isinstance(series.columns, dict) else {}
    if series.x_column and series.x_column in cols:
        if series.kind == "plot" and (series.meta or {}).get("xlabel"):
            return numeric(cols[series.x_column]), _declared_label(series.meta["xlabel"])
        return numeric(cols[series.x_column]), label_of(series, series.x_column)
    length = max((len(v) for v in cols.values() if isinstance(v, list)), default=0)
    return list(range(length)), "sample [1]"


def series_figure(curves: list[tuple[str, object]], quantity: str | None) -> Figure:
    """One quantity (or, for a declared plot and ``quantity=None``, all its columns) for one or more runs.

    ``curves`` is ``[(run label, Series)]``; with several runs each gets its own line (thesis 4.6.2:
    plots of all compared runs overlaid).
    """
    fig = new_figure()
    ax = fig.add_subplot()
    first = curves[0][1]
    meta = first.meta or {}
    declared = first.kind == "plot"
    columns = [quantity] if quantity else quantities(first)
    legend_names = meta.get("legend") or []
    all_columns = quantities(first)
    for label, series in curves:
        x, xlabel = abscissa(series)
        for column in columns:
            values = numeric((series.columns or {}).get(column))
            if not values:
                continue
            name = column
            if declared and column in all_columns and all_columns.index(column) < len(legend_names):
                name = _declared_label(legend_names[all_columns.index(column)])
            parts = [p for p in (label if len(curves) > 1 else "", name if len(columns) > 1 or declared
                                 else "") if p]
            ax.plot(x[:len(values)], values[:len(x)], label=", ".join(parts) or column, linewidth=1.4)
    ax.set_xlabel(xlabel)
    if declared and meta.get("ylabel"):
        ax.set_ylabel(_declared_label(meta["ylabel"]))
    else:
        ax.set_ylabel(label_of(first, columns[0]) if len(columns) == 1 else "value")
    title = meta.get("title") if declared else None
    ax.set_title(title or f"{first.name}: {quantity or ', '.join(columns)}")
    ax.grid(True, alpha=0.3)
    legend_below(fig, ax)
    return fig


def epsilon_of(reference_values: list[float], stored: float | None) -> float:
    """Global tolerance of thesis eq. 4.2, eps = 0.1 (max x_ref - min x_ref) / 2, unless stored by the check."""
    if stored is not None:
        return stored
    finite = [v for v in reference_values if math.isfinite(v)]
    return 0.1 * (max(finite) - min(finite)) / 2 if finite else 0.0


def band_half_width(level: float, eps: float) -> float:
    """|x - x_ref| below which Delta_k = 0.1 |x - x_ref| / eps (thesis eq. 4.3) stays below ``level``."""
    return level * eps / 0.1


def consistency_figure(result, run_series, reference_series, run_label: str, reference_label: str) -> Figure:
    """Thesis figure 4.11: a run's trajectory over its reference with the 5 % and 10 % acceptance bands.

    ``result`` is the ConsistencyResult (C, level, eps, first step out of band); the series hold the data.
    """
    fig = new_figure()
    ax = fig.add_subplot()
    quantity = result.quantity
    x_ref, xlabel = abscissa(reference_series)
    y_ref = numeric((reference_series.columns or {}).get(quantity))
    n = min(len(x_ref), len(y_ref))
    x_ref, y_ref = x_ref[:n], y_ref[:n]
    eps = epsilon_of(y_ref, result.epsilon)
    for name, level, color in LEVELS:
        half = band_half_width(level, eps)
        ax.fill_between(x_ref, [y - half for y in y_ref], [y + half for y in y_ref], color=color,
                        label=name, linewidth=0)
    ax.plot(x_ref, y_ref, color="#222222", linewidth=1.4, label=f"reference: {reference_label}")
    if run_series is not None:
        x_run, _ = abscissa(run_series)
        y_run = numeric((run_series.columns or {}).get(quantity))
        m = min(len(x_run), len(y_run))
        ax.plot(x_run[:m], y_run[:m], color="#1f5fbf", linewidth=1.4, linestyle="--", label=run_label)
    if result.first_bad_step is not None:
        ax.axvline(result.first_bad_step, color="#c0392b", linewidth=1.0,
                   label=f"first out of band: {result.first_bad_step:g}")
    c_text = "n/a" if result.value is None else f"{result.value:.4f}"
    ax.set_title(f"{result.series_name}: {quantity}  (C = {c_text}, {result.level})")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(label_of(reference_series, quantity))
    ax.grid(True, alpha=0.3)
    legend_below(fig, ax)
    return fig


def history_figure(runs, testcase_path: str, target_name: str) -> Figure:
    """Consistency C and wall time of a test case's runs over the successive builds of a target.

    ``runs`` are ordered oldest build first; one line per run configuration name.
    """
    fig = new_figure((6.4, 5.6))
    ax_c, ax_t = fig.subplots(2, 1, sharex=True)
    from webfrontend.presentation import revision_label

    revisions: list[str] = []
    for run in runs:
        if revision_label(run.build) not in revisions:
            revisions.append(revision_label(run.build))
    lines: dict[str, dict[str, list]] = {}
    for run in runs:
        line = lines.setdefault(run.name, {"x": [], "c": [], "t": []})
        line["x"].append(revisions.index(revision_label(run.build)))
        line["c"].append(math.nan if run.consistency_min is None else run.consistency_min)
        line["t"].append(math.nan if run.wall_time is None else run.wall_time)
    for name, line in sorted(lines.items()):
        ax_c.plot(line["x"], line["c"], marker="o", label=name)
        ax_t.plot(line["x"], line["t"], marker="o", label=name)
    ax_c.axhline(0.95, color="#2e8b57", linestyle=":", linewidth=1, label="C = 0.95 (perfect)")
    ax_c.axhline(0.90, color="#d68910", linestyle=":", linewidth=1, label="C = 0.90 (good)")
    ax_c.set_ylabel("lowest C [1]")
    fig.suptitle(f"{testcase_path} on {target_name}", fontsize="medium")
    ax_c.set_title("lowest consistency C per revision", fontsize="small")
    ax_t.set_title("engine wall time per revision", fontsize="small")
    ax_t.set_ylabel("wall time [s]")
    ax_t.set_xlabel("revision (oldest build first)")
    ax_t.set_xticks(range(len(revisions)))
    ax_t.set_xticklabels(revisions, rotation=20, ha="right", fontsize="small")
    for ax in (ax_c, ax_t):
        ax.grid(True, alpha=0.3)
    legend_below(fig, ax_c)
    return fig
