"""Links from the CLI into the dashboard: set ``HARNESS_DASHBOARD_URL`` (e.g. ``https://ci.example.org/dem``)
and ``harness ci`` and ``harness bisect`` print the commit page of what they built (webfrontend/urls.py:
``commits/TARGET/COMMIT/?machine=MACHINE``)."""
from __future__ import annotations

import os
from urllib.parse import quote, urlencode


def dashboard_url() -> str | None:
    """The dashboard's address without a trailing slash (None: not configured)."""
    url = os.environ.get("HARNESS_DASHBOARD_URL", "").strip()
    return url.rstrip("/") or None


def commit_page(target: str, commit: str, machine: str) -> str | None:
    """The dashboard's page of ``target`` at ``commit`` on ``machine`` (None without a dashboard URL)."""
    base = dashboard_url()
    if base is None:
        return None
    return f"{base}/commits/{quote(target)}/{quote(commit)}/?{urlencode({'machine': machine})}"
