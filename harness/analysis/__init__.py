"""What the stored runs say: version consistency against the reference (``harness check``), what a verdict
covers, comparisons of two builds, bisection, regressions over the history, scaling studies, the cross-code
matrix and the timing breakdown.

Owns: consistency (C of thesis eqs. 4.2-4.4), check, coverage, verdicts (the dashboard's verdicts from the
store), compare, slowdown, bisect, regressions, scaling, matrix, breakdown.
May import: ``harness.store``, ``harness.config``, ``harness.execution`` (bisect and scaling run builds) and
``harness.report`` (the JUnit writer of ``harness check``); never the commands.
"""
