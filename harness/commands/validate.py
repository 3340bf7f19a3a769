"""``harness validate [TARGET ...] [--testcases FOLDER]``: check every target definition and every run.config
its test case folders hold, without building or running anything. Exit code 0 when all are valid, 1 with a
problem (each printed as ``FILE: $.path: what is wrong``)."""
import sys

from harness.adapters.base import UserError

NAME = "validate"
HELP = "check every target and run.config (nothing is built or run)"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names (default: all)")
    parser.add_argument("--testcases", metavar="FOLDER",
                        help="check the test cases of this folder (for each target's engine) instead of the "
                             "targets' own test case folders")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.adapters import get_adapter
    from harness.config.targets import load_targets, with_testcases
    from harness.config.testcases import discover

    definitions, problems = load_targets(args.targets_dir)
    names = args.targets or sorted(definitions)
    unknown = [n for n in names if n not in definitions]
    problems += [f"unknown target {n!r} (or its definition has a problem above)" for n in unknown]
    testcases, entries = set(), 0
    for name in names:
        if name not in definitions:
            continue
        target = with_testcases(definitions[name], args.testcases)
        try:
            found, found_problems = discover(target, get_adapter(target.engine))
        except UserError as exc:
            problems.append(str(exc))
            continue
        problems += found_problems
        for case in found:
            testcases.add(case.path)
            for entry in case.runs:
                entries += 1
                problems += entry.problems
    problems = list(dict.fromkeys(problems))  # a test case shared by several targets: its problem once
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    def count(n, word):
        return f"{n} {word}{'' if n == 1 else 's'}"

    print(f"{count(len(names), 'target')}, {count(len(testcases), 'test case')}, "
          f"{count(entries, 'run configuration')} checked: {count(len(problems), 'problem')}")
    return 1 if problems else 0

