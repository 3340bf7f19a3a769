"""``harness scaling [TARGET ...] [-k PATTERN] [--no-run]``: how the codes scale with cores.

Runs the points of the run configurations that declare a ``scaling`` block (``harness.analysis.scaling``) one at a time
(a point timed while another runs measures the other's load), then prints per study the stepping time,
speedup, parallel efficiency, Karp-Flatt serial fraction and load imbalance per core count, and writes them as
CSV and JSON under ``$HARNESS_HOME/scaling/MACHINE/TARGET/TESTCASE/NAME.{csv,json}``.
"""
import json
import os
import sys

from harness.store import setup_store

NAME = "scaling"
HELP = "run scaling studies (speedup, parallel efficiency, serial fraction over threads or MPI ranks)"


def configure(parser):
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="target names or TARGET@REV (default: all)")
    parser.add_argument("-k", dest="pattern", metavar="PATTERN",
                        help="only studies whose 'testcase/run' contains PATTERN (or matches it as a glob)")
    parser.add_argument("--working-tree", action="store_true",
                        help="take test cases from the working tree instead of testcases_revision")
    parser.add_argument("--no-run", action="store_true", help="only tabulate the points already in the store")
    parser.add_argument("--profile", action="store_true",
                        help="record a profile of every point (harness run --profile)")


def run(args) -> int:
    setup_store()
    # imported when the command runs: the store's models need setup_store() first, and `harness --help` stays fast
    from harness.analysis import scaling
    from harness.commands.run import run_points
    from harness.config.revisions import expand
    from harness.config.testcases import matches
    from harness.execution.workspace import workspace
    from harness.report.textout import format_table
    from harness.store.runrecord import finite

    targets, problems = expand(args.targets, args.targets_dir)
    # scaling points are named NAME@cores=P: this selects exactly them; one at a time
    failed_runs, built = run_points(args, targets, problems, "@cores=*", jobs=1, profile=args.profile)
    found = 0
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    for target, build, runs in built:
        for study in scaling.studies_in_store(runs):
            if not matches(args.pattern, study.testcase, study.name):
                continue
            found += 1
            unit = "threads" if study.parallelism == "threads" else "MPI ranks"
            print(f"\n{target.name}@{build.commit[:10]}: {study.key}  ({study.kind} scaling over {unit})")
            print(format_table(scaling.format_study(study)))
            if max(p.cores for p in study.points) > cores:
                print(f"note: this machine has {cores} cores; points beyond share them")
            history = scaling.history(build.target_id, build.machine_id).get(study.key, [])
            mine = next((i for i, row in enumerate(history) if row["build"] == build.pk), None)
            if mine and history[mine]["worse"]:
                before, now = history[mine - 1], history[mine]
                print(f"scales worse: efficiency on {now['cores']} cores {now['efficiency']:.0%}, "
                      f"{before['efficiency']:.0%} at {before['commit'][:10]} (the previous build)")
            out = workspace().home / "scaling" / args.machine / target.name / study.testcase
            out.mkdir(parents=True, exist_ok=True)
            data = finite({"target": target.name, "commit": build.commit, **study.as_dict()})
            (out / f"{study.name}.json").write_text(json.dumps(data, indent=1, allow_nan=False))
            (out / f"{study.name}.csv").write_text(
                "cores,stepping_time_s,speedup,efficiency,serial_fraction,imbalance,state\n"
                + "".join(f"{p.cores},{_csv(p.time)},{_csv(p.speedup)},{_csv(p.efficiency)},"
                          f"{_csv(p.serial_fraction)},{_csv(p.imbalance)},{p.state}\n" for p in study.points))
            print(f"table: {out / (study.name + '.csv')}")
    if not found:
        print("harness: no scaling runs found (declare a 'scaling' block in a run.config)", file=sys.stderr)
        return 5 if not failed_runs else 1
    return 1 if failed_runs or problems else 0


def _csv(value) -> str:
    return "" if value is None or value != value else repr(float(value))
