"""Server time and query count of the dashboard pages that read every run of a build, with 10,000 runs.

    python benchmarks/dashboard_pages.py [--runs 10000] [--repeat 3]

The store is the one the browser scale test uses (tests/web/test_browser_scale.py): the dashboard tests'
small store (tests/web/dashboard_data.py) and bulk runs of the current dem-master build up to ``--runs``,
in a temporary SQLite store. Each page is rendered through Django's test client (the full request/response
cycle without the network or the browser); the median of ``--repeat`` renderings and the number of SQL
queries are printed. Goal: < 1 s a page (the browser adds the drawing).
"""
from __future__ import annotations

import argparse
import sys

from dashboard_timing import dashboard_store, time_pages


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs in the store (default 10000)")
    parser.add_argument("--repeat", type=int, default=3, help="renderings per page (default 3)")
    parser.add_argument("--profile", metavar="PAGE", help="print where one page's time goes (cProfile, top 25)")
    parser.add_argument("--sort", default="cumulative", help="--profile's order: cumulative or tottime")
    args = parser.parse_args()
    with dashboard_store() as (home, client):
        # the dashboard tests' store (tests/web, on the path through dashboard_timing) once Django is set up
        from dashboard_data import add_bulk_runs, make_store

        from harness.store.models import Run

        s = make_store(home / "runs")
        add_bulk_runs(args.runs - Run.objects.count(), s["ws1"], s["master"], s["new_build"])
        pages = [
            ("compare builds", f"/builds/compare/?a={s['older'].build_id}&b={s['new_build'].pk}"),
            ("commit page", f"/commits/dem-master/{s['new_build'].commit}/?machine=ws1"),
            ("regressions", f"/regressions/?machine={s['ws1'].pk}"),
            ("search listing runs", "/?q=bulk"),
            ("overview", "/"),
            ("scaling studies", "/scaling/"),
            ("timing breakdown", f"/breakdown/{s['master'].pk}/{s['inconsistent'].testcase.path}/"),
        ]
        if args.profile:
            # only for --profile
            import cProfile
            import pstats

            url = dict(pages)[args.profile]
            client.get(url)
            profiler = cProfile.Profile()
            profiler.runcall(client.get, url)
            pstats.Stats(profiler).sort_stats(args.sort).print_stats(25)
            return 0
        time_pages(client, pages, args.repeat, goal_s=1.0, heading=f"{Run.objects.count()} runs; ")
    return 0


if __name__ == "__main__":
    sys.exit(main())
