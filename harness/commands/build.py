"""``harness build [TARGET ...] [--force] [-j N]``: build targets at their revisions (cached by definition and
commit). Without names every target except the on-demand ones (``"on_demand": true``, e.g. liggghts-src)."""
import sys

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "build"
HELP = "build targets at their revisions (cached; --force rebuilds)"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all but the "
                        "on-demand targets)")
    parser.add_argument("--force", action="store_true", help="rebuild even if a build (complete or failed) is "
                        "stored")
    parser.add_argument("-j", "--jobs", type=int, default=None, metavar="N",
                        help="parallel compile jobs (default: the target's 'jobs', else the machine's cores)")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.revisions import expand
    from harness.execution.builds import build_target

    if args.jobs is not None and args.jobs < 1:
        raise UserError(f"-j {args.jobs}: must be at least 1")
    setup_store()
    targets, problems = expand(args.targets, args.targets_dir)
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    status = 1 if problems else 0
    say = (lambda text: print(text, file=sys.stderr))
    for target in targets:
        try:
            build = build_target(target, args.machine, force=args.force, log=say, jobs=args.jobs)
        except UserError as exc:
            print(f"harness: {exc}", file=sys.stderr)
            status = 1
            continue
        took = f" (built in {build.duration:.1f} s)" if build.duration is not None else ""
        print(f"{target.name}: {build.commit[:12]} {build.status}{took} {build.folder}")
    return status
