"""``harness new testcase NAME [--in FOLDER]``: write a working test case to start from (harness.config.scaffold)."""
from pathlib import Path

NAME = "new"
HELP = "write a new test case to start from: a bouncing sphere with one expectation"


def configure(parser):
    parser.add_argument("kind", choices=["testcase"], help="what to write (a test case)")
    parser.add_argument("name", metavar="NAME", help="the test case's folder name")
    parser.add_argument("--in", dest="parent", metavar="FOLDER", default=".",
                        help="the folder to write it in (default: the current folder)")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.config.scaffold import new_testcase

    parent = Path(args.parent).expanduser().resolve()
    for path in new_testcase(parent, args.name):
        print(f"wrote {path}")
    print(f"next: harness validate --testcases {parent}\n"
          f"      harness run dem --no-reference --testcases {parent} -k {args.name}\n"
          f"      (README.md, 'Your first test case', goes on from here)")
    return 0
