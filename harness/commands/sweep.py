"""``harness sweep [TARGET ...] [-k PATTERN] [-j N] [--no-run]``: what accuracy costs in time.

Runs the sweep points of the targets' run configurations that declare a ``sweep`` block (see
``harness.config.sweep``), then writes for each sweep a CSV table and a log-log plot of error against wall time
and against the swept value, with the observed convergence order, under ``$HARNESS_HOME/sweeps/``.
"""
import sys

from harness.store import setup_store

NAME = "sweep"
HELP = "run sweeps (error against run time over a grid of a variable) and plot them"


def configure(parser):
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.commands.run import add_selection

    add_selection(parser, what="sweeps")
    parser.add_argument("--no-run", action="store_true", help="only tabulate and plot runs already in the store")


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.commands.run import run_points
    from harness.config import sweep as sw
    from harness.config.targets import select_targets
    from harness.config.testcases import matches
    from harness.execution.workspace import workspace
    from harness.report.textout import format_table

    targets, problems = select_targets(args.targets, args.targets_dir)
    # sweep points are named NAME@VARIABLE=VALUE: '@' selects exactly them
    failed_runs, built = run_points(args, targets, problems, "@*", jobs=args.jobs)
    found = 0
    for target, build, runs in built:
        for result in sw.sweeps_in_store(runs):
            if not matches(args.pattern, result.testcase, result.name):
                continue
            found += 1
            out = workspace().sweeps / args.machine / target.name / result.testcase
            out.mkdir(parents=True, exist_ok=True)
            result.table.to_csv(out / f"{result.name}.csv", index=False)
            title = f"{target.name}: {result.testcase}/{result.name}"
            sw.plot(result.table, result.spec, title, out / f"{result.name}.png")
            order = result.order
            print(f"\n{title}  (error of {result.spec['error']['quantity']}, observed order "
                  f"{'n/a' if order is None else f'{order:.2f}'})")
            rows = [(result.spec["variable"], "run s", "quantity", "error", "state")]
            for _, row in result.table.iterrows():
                rows.append((f"{row['value']:g}", _number(row["run_time"], ".3f"), _number(row["quantity"], ".6g"),
                             _number(row["error"], ".3g"), row["state"]))
            print(format_table(rows))
            print(f"table: {out / (result.name + '.csv')}\nplot:  {out / (result.name + '.png')}")
    if not found:
        print("harness: no sweep runs found (declare a 'sweep' block in a run.config)", file=sys.stderr)
        return 1
    return 1 if failed_runs or problems else 0


def _number(value, spec: str) -> str:
    """A table cell: '-' for a missing value (a run that failed, the finest run's own error)."""
    return "-" if value is None or value != value else format(value, spec)
