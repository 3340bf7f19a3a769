"""``harness import FOLDER``: bring run folders (with their run.json) from another machine into the store."""
import sys

from harness.adapters.base import UserError
from harness.store import setup_store

NAME = "import"
HELP = "import run folders (run.json records) into the store"


def configure(parser):
    parser.add_argument("folder", help="a run folder or a folder holding run folders")
    parser.add_argument("--as-machine", metavar="NAME", help="record the runs under this machine name")
    parser.add_argument("--replace", action="store_true",
                        help="replace stored runs that an imported record contradicts (default: report and skip)")


def run(args) -> int:
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.store.records import import_folder

    setup_store()
    if args.as_machine:
        # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
        from harness.execution.workspace import segment_problem

        if segment_problem(args.as_machine):
            raise UserError(f"--as-machine: {segment_problem(args.as_machine)}")
    runs, problems = import_folder(args.folder, args.as_machine, replace=args.replace)
    for problem in problems:
        print(f"harness: {problem}", file=sys.stderr)
    for run in runs:
        print(f"{run.machine.name} {run.target.name} {run.testcase.path}/{run.name}: {run.state}")
    print(f"imported {len(runs)} runs; {len(problems)} problems")
    return 1 if problems else 0
