"""``harness import FOLDER``: bring run folders (with their run.json) from another machine into the store."""
import sys

NAME = "import"
HELP = "import run folders (run.json records) into the store"


def configure(parser):
    parser.add_argument("folder", help="a run folder or a folder holding run folders")
    parser.add_argument("--as-machine", metavar="NAME", help="record the runs under this machine name")


def run(args) -> int:
    from harness.records import import_folder
    from harness.store import setup_store

    setup_store()
    runs, problems = import_folder(args.folder, args.as_machine)
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    for run in runs:
        print(f"{run.machine.name} {run.target.name} {run.testcase.path}/{run.name}: {run.state}")
    print(f"imported {len(runs)} runs; {len(problems)} problems")
    return 1 if problems else 0
