"""Server time and query count of the dashboard's overview and folder pages with 10,000 runs in the store.

    python benchmarks/dashboard_overview.py [--runs 10000]

Generates the runs in a temporary SQLite store (2 machines x 2 targets x 5 builds x test cases x 2 run
configurations, test cases in a three-level folder tree, consistency results and a few overrides), then
renders each page through Django's test client (the full request/response cycle without the network) and
prints the median of 5 renderings and the number of SQL queries. Goal: < 0.5 s per page.
"""
from __future__ import annotations

import argparse
import sys
import time
from datetime import datetime, timedelta, timezone

from dashboard_timing import dashboard_store, time_pages


def generate(total_runs: int) -> dict:
    from django.contrib.auth import get_user_model

    from harness.store.models import (
        Build,
        ConsistencyResult,
        Machine,
        Override,
        Run,
        Target,
        TestCase,
    )

    t0 = datetime(2026, 1, 1, tzinfo=timezone.utc)
    machines = [Machine.objects.create(name=f"node{i}") for i in range(2)]
    reference = Target.objects.create(name="dem-v1")
    targets = [reference, Target.objects.create(name="dem-master", reference=reference)]
    builds_per_target, run_names = 5, ("serial", "mpi4")
    n_cases = max(1, total_runs // (len(machines) * len(targets) * builds_per_target * len(run_names)))
    families = ("contact_models", "walls", "packing", "cohesion", "mesh")
    cases = TestCase.objects.bulk_create([
        TestCase(path=f"{families[i % 5]}/group{i % 7}/case{i:04d}") for i in range(n_cases)])
    states = ("consistency_checked", "consistency_checked", "post_processed", "failed", "not_executed",
              "outdated", "executed", "consistency_checked")
    runs = []
    for m in machines:
        for t in targets:
            for b in range(builds_per_target):
                # the newest build is the current one: the overview counts its runs
                build = Build.objects.create(target=t, machine=m, revision=f"r{b}", commit=f"{b:040d}",
                                             definition_hash="h", status="complete",
                                             committed_at=t0 + timedelta(days=b), current=b == builds_per_target - 1)
                for k, case in enumerate(cases):
                    for name in run_names:
                        state = states[(k + b + len(runs)) % len(states)]
                        checked = state == "consistency_checked"
                        level = ("perfect", "good", "inconsistent")[k % 3] if checked else ""
                        runs.append(Run(machine=m, target=t, build=build, testcase=case, name=name, state=state,
                                        wall_time=0.5 + (k % 10) * 0.1, consistency=level,
                                        consistency_min=(0.99, 0.93, 0.7)[k % 3] if checked else None,
                                        timing={"pair": 0.3, "total": 0.5}))
    Run.objects.bulk_create(runs, batch_size=2000)
    inconsistent = list(Run.objects.filter(consistency="inconsistent").values_list("id", "reference_run_id"))
    any_ref = Run.objects.filter(target=reference).first()
    ConsistencyResult.objects.bulk_create([
        ConsistencyResult(run_id=rid, reference_run=any_ref, series_kind="thermo", series_name="thermo",
                          quantity=q, value=0.7 if q == "ke" else 0.99, level="inconsistent" if q == "ke" else "perfect")
        for rid, _ in inconsistent for q in ("ke", "rke", "atoms")], batch_size=2000)
    user = get_user_model().objects.create_user("reviewer")
    Override.objects.bulk_create([Override(run_id=rid, user=user, reason="tolerable", quantity="ke" if i % 2 else "")
                                  for i, (rid, _) in enumerate(inconsistent[::10])])
    return {"runs": Run.objects.count(), "cases": n_cases, "machine": machines[0].pk, "target": targets[1].pk}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs to generate (default 10000)")
    args = parser.parse_args()
    with dashboard_store() as (home, client):
        start = time.perf_counter()
        info = generate(args.runs)
        print(f"generated {info['runs']} runs over {info['cases']} test cases in "
              f"{time.perf_counter() - start:.1f} s (SQLite, {(home / 'harness.sqlite3').stat().st_size / 1e6:.1f} MB)")
        base = f"/m/{info['machine']}/t/{info['target']}/"
        pages = [("overview", "/"), ("overview, consistency mode", "/?mode=consistency"),
                 ("folder root", base), ("folder contact_models", base + "f/contact_models/"),
                 ("folder, failed only", base + "f/contact_models/?show=failed"),
                 ("test case (run list)", base + "f/contact_models/group0/case0000/")]
        time_pages(client, pages, repeat=5, goal_s=0.5)
    return 0


if __name__ == "__main__":
    sys.exit(main())
