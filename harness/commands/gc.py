"""``harness gc [--keep-builds N] [--dry-run]``: remove old run and build folders (never store rows)."""

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "gc"
HELP = "remove run folders and builds of old revisions by a stated policy (store rows are kept)"


def configure(parser):
    parser.add_argument("--keep-builds", type=int, default=2, metavar="N",
                        help="besides the current build, keep the N most recent builds of each target (default 2)")
    parser.add_argument("--dry-run", action="store_true", help="only list what would be removed")
    parser.add_argument("--all-machines", action="store_true",
                        help="also collect folders of runs recorded under other machine names")


def run(args) -> int:
    if args.keep_builds < 0:
        raise UserError("--keep-builds must be at least 0")
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.execution.gc import collect, collect_profiles

    result = collect(args.keep_builds, args.dry_run, None if args.all_machines else args.machine)
    verb = "would remove" if args.dry_run else "removed"
    for path in result.build_folders + result.run_folders:
        print(f"{verb} {path}")
    for what in result.skipped:
        print(f"skipped {what}")
    samples = collect_profiles(args.dry_run, None if args.all_machines else args.machine)
    for path in samples.run_folders:
        print(f"{verb} {path}")
    if samples.run_folders:
        print(f"{verb} the raw profile samples of {len(samples.run_folders)} runs of builds that are not current, "
              f"{samples.bytes / 1e6:.1f} MB (their folded stacks stay)")
    print(f"{verb} {len(result.run_folders)} run folders and {len(result.build_folders)} build folders, "
          f"{result.bytes / 1e6:.1f} MB"
          + (f"; skipped {len(result.skipped)} in use" if result.skipped else "")
          + "; the store keeps every run's record (policy: the current build and the "
          f"{args.keep_builds} most recent other builds of each target keep their files)")
    return 0
