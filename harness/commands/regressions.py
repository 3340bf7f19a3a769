"""``harness regressions [TARGET] [-k PATTERN] [--json]``: builds where stepping time or a quantity changed."""
import json

from harness.store import setup_store

NAME = "regressions"
HELP = "mark the commits where a test case's stepping time or physics changed over a target's history"


def configure(parser):
    parser.add_argument("target", nargs="?", metavar="TARGET", help="target name (default: all)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN", help="only runs whose 'testcase/run' match")
    parser.add_argument("--sigma", type=float, default=3.0, help="speed: k in mean +/- k sd (default 3)")
    parser.add_argument("--window", type=int, default=5, help="speed: previous builds the mean is over (default 5)")
    parser.add_argument("--min-change", type=float, default=0.1,
                        help="speed: smallest relative change reported (default 0.1 = 10 %%)")
    parser.add_argument("--json", action="store_true", help="print the changes as JSON")
    parser.add_argument("--builds", action="store_true", help="also list every build with its build time "
                        "(failed builds too); with --json, print the builds instead of the changes")


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis.regressions import build_times, comparable, histories
    from harness.execution.scheduler import format_table

    found = histories(args.machine, args.target, args.pattern, args.sigma, args.window, args.min_change)
    changes = [(h, c) for h in found for c in h.changes]
    builds = build_times(args.machine, args.target) if args.builds else []
    if args.json and args.builds:
        print(json.dumps([{"target": b.target, "commit": b.commit, "status": b.status, "seconds": b.seconds,
                           "error": b.error, "ccache_hits": b.ccache_hits} for b in builds], indent=1))
        return 5 if not builds else 0
    if args.json:
        print(json.dumps([{"target": h.target, "testcase": h.testcase, "run": h.run, "commit": c.commit,
                           "previous_commit": c.previous_commit, "kind": c.kind, "detail": c.detail}
                          for h, c in changes], indent=1))
    else:
        rows = [("target", "test case", "run", "commit", "after", "change", "detail")]
        for h, c in changes:
            rows.append((h.target, h.testcase, h.run, c.commit[:10], c.previous_commit[:10], c.kind, c.detail))
        print(format_table(rows) if changes else "no changes found")
        print(f"{len(found)} histories, {comparable(found)} of them with runs of two or more builds (only those "
              f"can change), {sum(len(h.points) for h in found)} runs, {len(changes)} changes")
        if args.builds:
            rows = [("target", "commit", "committed", "build", "build time", "ccache hits", "error")]
            for b in builds:
                rows.append((b.target, b.commit[:10], b.committed_at.date().isoformat() if b.committed_at else "-",
                             b.status, f"{b.seconds:.1f} s" if b.seconds is not None else "-",
                             "-" if b.ccache_hits is None else str(b.ccache_hits), b.error))
            print(format_table(rows))
    return 5 if not found and not builds else 0
