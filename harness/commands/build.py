"""``harness build [TARGET ...] [--force]``: build targets at their revisions (cached by definition and commit)."""
import sys

NAME = "build"
HELP = "build targets at their revisions (cached; --force rebuilds)"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names, TARGET@REV (any git revision) or TARGET@A..B (default: all)")
    parser.add_argument("--force", action="store_true", help="rebuild even if a complete build is cached")


def run(args) -> int:
    from harness.adapters.base import UserError
    from harness.builds import build_target
    from harness.store import setup_store
    from harness.revisions import expand

    setup_store()
    targets, problems = expand(args.targets, args.targets_dir)
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    status = 1 if problems else 0
    say = (lambda text: print(text, file=sys.stderr))
    for target in targets:
        try:
            build = build_target(target, args.machine, force=args.force, log=say)
        except UserError as exc:
            print(f"harness: {exc}", file=sys.stderr)
            status = 1
            continue
        print(f"{target.name}: {build.commit[:12]} {build.status} {build.folder}")
    return status
