"""Why B is slower than A: the timing breakdown and, where both runs were profiled, the profile against each other.

Used by ``harness bisect --slower`` (the first slow commit against GOOD) and ``harness compare --profile A B``.
For each pair of runs the section of the breakdown whose time grew most comes first (``harness.analysis.breakdown.diff``),
then the functions whose share of the profile grew most (``harness.execution.profiles.function_diff``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from harness.analysis import breakdown as bd
from harness.execution import profiles


@dataclass
class Explanation:
    """One pair of runs: its stepping-time ratio B/A, the breakdown diff and the profile diff (None when either
    run has no profile)."""

    testcase: str
    run: str
    time_ratio: float | None
    sections: list[dict] = field(default_factory=list)
    functions: list[dict] | None = None

    @property
    def top_section(self) -> str | None:
        return self.sections[0]["section"] if self.sections and self.sections[0]["delta"] > 0 else None

    @property
    def top_function(self) -> str | None:
        return self.functions[0]["function"] if self.functions else None

    def as_dict(self) -> dict:
        return {"testcase": self.testcase, "run": self.run, "time_ratio": self.time_ratio,
                "sections": self.sections, "functions": (self.functions or [])[:20]}

    def lines(self, functions: int = 10) -> list[str]:
        ratio = f"{self.time_ratio:.3f}x" if self.time_ratio else "n/a"
        out = [f"{self.testcase}/{self.run}: stepping time B/A {ratio}"]
        if self.sections:
            top = self.top_section
            out.append(f" breakdown (grew most: {top})" if top else " breakdown (no section grew)")
            out += bd.format_diff(self.sections)
        if self.functions is not None:
            top = self.top_function
            out.append(f" profile (share grew most: {top})")
            out += profiles.format_function_diff(self.functions, functions)
        return out


def explain_pair(pair) -> Explanation:
    """The explanation of one ``harness.analysis.compare.PairComparison`` whose runs both ran."""
    a, b = pair.a, pair.b
    sections = bd.diff(a.breakdown or {}, b.breakdown or {}) if (a.breakdown and b.breakdown) else []
    stacks_a, stacks_b = profiles.run_profile(a), profiles.run_profile(b)
    functions = profiles.function_diff(stacks_a, stacks_b) if stacks_a and stacks_b else None
    return Explanation(pair.testcase, pair.run, pair.time_ratio, sections, functions)


def explain(comparison, limit: int | None = None) -> list[Explanation]:
    """Explanations of a comparison's pairs that both ran, the most slowed-down first."""
    pairs = [p for p in comparison.pairs if p.a is not None and p.b is not None and p.time_ratio]
    pairs.sort(key=lambda p: p.time_ratio, reverse=True)
    return [explain_pair(p) for p in pairs[:limit]]
