"""What the dashboard benchmarks share: a throw-away store with Django set up, and the timing of pages.

``dashboard_store`` opens a temporary SQLite store with the dashboard's settings and yields (its folder, a
Django test client); ``time_pages`` renders each page through the client (the full request/response cycle
without the network or the browser) and prints the median server time of ``repeat`` renderings, the SQL
queries and whether the slowest page meets the goal. benchmarks/dashboard_overview.py and
benchmarks/dashboard_pages.py use them.
"""
from __future__ import annotations

import contextlib
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "web")]


@contextlib.contextmanager
def dashboard_store():
    """(the store's folder, a Django test client) over a fresh, migrated temporary SQLite store."""
    with tempfile.TemporaryDirectory(prefix="dashboard-bench-") as home:
        os.environ["HARNESS_HOME"] = home
        os.environ.pop("HARNESS_DATABASE_URL", None)
        os.environ["DJANGO_SETTINGS_MODULE"] = "webfrontend.settings"
        # Django is imported once the settings above name this store
        import django
        from django.core.management import call_command

        django.setup()
        call_command("migrate", verbosity=0)
        from django.test import Client
        from django.test.utils import setup_test_environment

        setup_test_environment()
        yield Path(home), Client()


def measure(client, url: str, repeat: int) -> tuple[float, int, int]:
    """(median seconds, queries, status) of rendering ``url``."""
    # Django is set up by dashboard_store
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    times = []
    for _ in range(repeat):
        with CaptureQueriesContext(connection) as ctx:
            start = time.perf_counter()
            response = client.get(url)
            times.append(time.perf_counter() - start)
    return statistics.median(times), len(ctx.captured_queries), response.status_code


def time_pages(client, pages: list[tuple[str, str]], repeat: int, goal_s: float, heading: str = "") -> float:
    """Print a row per (name, url) page - server time and queries - and the slowest against ``goal_s``;
    returns the slowest page's time in s. Every page must answer 200."""
    width = max(len(name) for name, _ in pages) + 2
    print(f"{heading}{'page':{width}} {'server time':>12} {'queries':>8}")
    worst = 0.0
    for name, url in pages:
        seconds, queries, status = measure(client, url, repeat)
        assert status == 200, (url, status)
        worst = max(worst, seconds)
        print(f"{name:{width}} {seconds * 1000:9.1f} ms {queries:8d}")
    print(f"slowest page {worst * 1000:.1f} ms (goal < {goal_s * 1000:.0f} ms): "
          f"{'ok' if worst < goal_s else 'TOO SLOW'}")
    return worst
