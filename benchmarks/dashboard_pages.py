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
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "web")]


def measure(client, url: str, repeat: int) -> tuple[float, int, int]:
    """(median seconds, queries, status) of rendering ``url``."""
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    times = []
    for _ in range(repeat):
        with CaptureQueriesContext(connection) as ctx:
            start = time.perf_counter()
            response = client.get(url)
            times.append(time.perf_counter() - start)
    return statistics.median(times), len(ctx.captured_queries), response.status_code


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs in the store (default 10000)")
    parser.add_argument("--repeat", type=int, default=3, help="renderings per page (default 3)")
    parser.add_argument("--profile", metavar="PAGE", help="print where one page's time goes (cProfile, top 25)")
    parser.add_argument("--sort", default="cumulative", help="--profile's order: cumulative or tottime")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="dashboard-bench-") as home:
        os.environ["HARNESS_HOME"] = home
        os.environ.pop("HARNESS_DATABASE_URL", None)
        os.environ["DJANGO_SETTINGS_MODULE"] = "webfrontend.settings"
        import django
        from django.core.management import call_command

        django.setup()
        call_command("migrate", verbosity=0)
        from django.test import Client
        from django.test.utils import setup_test_environment

        from dashboard_data import add_bulk_runs, make_store
        from harness.models import Run

        setup_test_environment()
        s = make_store(Path(home) / "runs")
        add_bulk_runs(args.runs - Run.objects.count(), s["ws1"], s["master"], s["new_build"])
        client = Client()
        pages = [
            ("compare builds", f"/builds/compare/?a={s['older'].build_id}&b={s['new_build'].pk}"),
            ("commit page", f"/commits/dem-master/{s['new_build'].commit}/?machine=ws1"),
            ("regressions", f"/regressions/?machine={s['ws1'].pk}"),
            ("search listing runs", "/?q=bulk"),
            ("overview", "/"),
        ]
        if args.profile:
            import cProfile
            import pstats

            url = dict(pages)[args.profile]
            client.get(url)
            profiler = cProfile.Profile()
            profiler.runcall(client.get, url)
            pstats.Stats(profiler).sort_stats(args.sort).print_stats(25)
            return 0
        print(f"{Run.objects.count()} runs; {'page':24} {'server time':>12} {'queries':>8}")
        worst = 0.0
        for name, url in pages:
            seconds, queries, status = measure(client, url, args.repeat)
            assert status == 200, (url, status)
            worst = max(worst, seconds)
            print(f"{name:24} {seconds * 1000:9.1f} ms {queries:8d}")
        print(f"slowest page {worst * 1000:.1f} ms (goal < 1000 ms): {'ok' if worst < 1.0 else 'TOO SLOW'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
