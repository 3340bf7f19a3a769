"""``harness matrix [TARGET ...] [-k PATTERN] [--csv FILE] [--json FILE] [--min-level LEVEL]``: the cross-code
consistency matrix (``harness.analysis.matrix``): C of every target's run against every other target's run of the same
test case content, per quantity (ke, rke, atoms). Default targets: those named ``*-crosscode``.

Writes ``$HARNESS_HOME/matrix/matrix.json`` and ``matrix.csv`` (for the dashboard) besides any ``--csv`` /
``--json`` file. Exit code 0; with ``--min-level good`` (or ``perfect``) 1 when a cell is below it; 5 when no
test case was run by two of the targets.
"""
import sys

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "matrix"
HELP = "cross-code consistency matrix: every target against every other on the test cases they share"
LEVEL_ORDER = {"perfect": 2, "good": 1}


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET",
                        help="targets to compare (default: all targets named *-crosscode)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("--csv", metavar="FILE", help="also write the cells as CSV to FILE")
    parser.add_argument("--json", metavar="FILE", help="also write the matrix as JSON to FILE")
    parser.add_argument("--min-level", choices=sorted(LEVEL_ORDER), default=None,
                        help="exit 1 when a cell is below this level")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.matrix import (
        _c,
        build_matrix,
        format_matrix,
        write_csv,
        write_json,
    )
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.targets import select_targets
    from harness.execution.builds import record_current_build
    from harness.execution.workspace import workspace

    setup_store()
    targets, problems = select_targets(args.targets, args.targets_dir)
    if not args.targets:
        targets = [t for t in targets if t.name.endswith("-crosscode")]
    if len(targets) < 2:
        raise UserError("the matrix needs at least two targets (name them, or define *-crosscode targets)")
    matrix = build_matrix({t.name: record_current_build(t, args.machine) for t in targets}, args.machine,
                          args.pattern)
    for problem in problems + matrix.problems:
        print(f"harness: {problem}", file=sys.stderr)
    if not matrix.cells:
        print("no test case run was run by two of the targets (run 'harness run " + " ".join(t.name for t in targets)
              + "' first)")
        return 5
    print(format_matrix(matrix))
    folder = workspace().home / "matrix"
    write_json(matrix, folder / "matrix.json")
    write_csv(matrix, folder / "matrix.csv")
    if args.csv:
        write_csv(matrix, args.csv)
    if args.json:
        write_json(matrix, args.json)
    below = []
    if args.min_level:
        wanted = LEVEL_ORDER[args.min_level]
        below = [c for c in matrix.cells if LEVEL_ORDER.get(c.level, 0) < wanted]
    pairs = matrix.lowest()
    print(f"\n{len(matrix.runs)} test case runs, {len(matrix.cells)} cells; lowest C per pair (code | reference):")
    for (code, reference), cell in sorted(pairs.items()):
        value = _c(cell.value)
        print(f"  {code} | {reference}: {value} {cell.level} ({cell.testcase}/{cell.run} {cell.quantity})")
    print(f"matrix written to {folder}")
    if below:
        print(f"{len(below)} cell(s) below {args.min_level}", file=sys.stderr)
        return 1
    return 0
