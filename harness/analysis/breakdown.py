"""Where the stepping time went: every code's timing breakdown in one vocabulary, and two breakdowns compared.

Each engine adapter reads its code's sections (``EngineAdapter.read_breakdown``) into the sections below, in
seconds summed over the run blocks of a run, with ``min``/``avg``/``max`` over MPI ranks where the code prints
them (LAMMPS' "MPI task timing breakdown" table; LIGGGHTS 3.8 prints averages only)::

    {"sections": {"pair": {"avg": 1.2, "min": 1.1, "max": 1.4}, "neighbor": {"avg": 0.1}, ...},
     "total": 2.0, "ranks": 2, "imbalance": 1.17, "imbalance_of": "pair time"}

``total`` is the loop time (the stepping time of ``harness.store.runrecord.stepping_time_of``), ``ranks`` the MPI
ranks (1 for serial and threaded runs). Load imbalance is max/avg over ranks (thesis ch. 7.2): of the pair
time where the code prints per-rank times, else of the particles per rank (``Nlocal ... ave ... max``); 1 is
perfect balance, 2 on two ranks means one rank did all the work.
"""
from __future__ import annotations

import math

#: the harness' sections, in the order they are drawn (stacked bars, tables)
SECTIONS = ("pair", "neighbor", "communication", "modify", "output", "other")
#: the short keys of ``Run.timing`` (and of the engines' own timing.json) for each section
TIMING_KEYS = {"pair": "pair", "neigh": "neighbor", "comm": "communication", "modify": "modify",
               "output": "output", "other": "other"}


def _number(value) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def from_timing(timing: dict, ranks: int = 1) -> dict:
    """A breakdown from a timing dict in the short keys (pair, neigh, comm, modify, output, other, total).

    For codes that report one time per section (the bundled engine, YADE, a generic code): ``avg`` only.
    An empty or unusable timing gives ``{}``.
    """
    sections = {}
    for key, section in TIMING_KEYS.items():
        value = _number((timing or {}).get(key))
        if value is not None:
            sections[section] = {"avg": value}
    total = _number((timing or {}).get("total"))
    if not sections and total is None:
        return {}
    return {"sections": sections, "total": total, "ranks": int(ranks), "imbalance": None, "imbalance_of": ""}


def of_run(run) -> dict:
    """A run's breakdown as stored (``Run.breakdown``), else one from its short-key ``timing`` (runs stored or
    imported before breakdowns were read): every page and command reads a run's sections through this."""
    return run.breakdown or from_timing(run.timing if isinstance(run.timing, dict) else {})


def add_block(breakdown: dict, block: dict) -> dict:
    """``breakdown`` plus one run block's breakdown (times summed; min and max summed too: the rank that is
    slowest in every block bounds the sum from above)."""
    if not breakdown:
        return {**block, "sections": {k: dict(v) for k, v in block.get("sections", {}).items()}}
    for section, values in block.get("sections", {}).items():
        into = breakdown["sections"].setdefault(section, {})
        for stat, value in values.items():
            into[stat] = into.get(stat, 0.0) + value
    if block.get("total") is not None:
        breakdown["total"] = (breakdown.get("total") or 0.0) + block["total"]
    breakdown["ranks"] = max(breakdown.get("ranks") or 1, block.get("ranks") or 1)
    return breakdown


def imbalance_of_sections(breakdown: dict, section: str = "pair") -> float | None:
    """max/avg over ranks of one section's time, when the code printed per-rank times; else None."""
    values = breakdown.get("sections", {}).get(section, {})
    avg, top = values.get("avg"), values.get("max")
    if avg and top is not None and avg > 0:
        return top / avg
    return None


def section_seconds(breakdown: dict) -> dict[str, float]:
    """Average seconds per section, every section of ``SECTIONS`` present (0 when the code has none)."""
    sections = (breakdown or {}).get("sections", {})
    return {name: float(sections.get(name, {}).get("avg") or 0.0) for name in SECTIONS}


def shares(breakdown: dict) -> dict[str, float]:
    """Fraction of the loop time per section (sums to 1 when the sections add up to the total)."""
    seconds = section_seconds(breakdown)
    total = breakdown.get("total") or sum(seconds.values())
    return {k: (v / total if total else 0.0) for k, v in seconds.items()}


def diff(a: dict, b: dict) -> list[dict]:
    """Sections of two breakdowns, the one whose time grew most first.

    Each row: ``section``, ``a`` and ``b`` (s), ``delta`` (s, b - a), ``ratio`` (b/a or None), and ``of_growth``
    (delta as a fraction of the growth of the loop time: 1.0 when this section explains all of it).
    """
    sa, sb = section_seconds(a), section_seconds(b)
    grown = (b.get("total") or sum(sb.values())) - (a.get("total") or sum(sa.values()))
    rows = []
    for name in SECTIONS:
        delta = sb[name] - sa[name]
        rows.append({"section": name, "a": sa[name], "b": sb[name], "delta": delta,
                     "ratio": sb[name] / sa[name] if sa[name] > 0 else None,
                     "of_growth": delta / grown if grown > 0 else None})
    return sorted(rows, key=lambda r: r["delta"], reverse=True)


def format_diff(rows: list[dict], limit: int = 6) -> list[str]:
    """Text lines of ``diff``: section, seconds before and after, growth."""
    lines = [f"  {'section':<14}{'A s':>10}{'B s':>10}{'B - A s':>10}  of the growth"]
    for row in rows[:limit]:
        share = f"{row['of_growth']:.0%}" if row["of_growth"] is not None else "-"
        lines.append(f"  {row['section']:<14}{row['a']:>10.4g}{row['b']:>10.4g}{row['delta']:>+10.4g}  {share}")
    return lines
