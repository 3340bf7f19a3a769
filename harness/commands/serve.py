"""``harness serve [--production]``: the dashboard over the store.

Development (default): Django's development server (``runserver``) with ``webfrontend.settings``.
Production (``--production``): gunicorn serving ``webfrontend.wsgi`` with ``webfrontend.settings_production``
(DEBUG off, static files collected and served by whitenoise, secure cookies and HSTS; it needs
``HARNESS_SECRET_KEY`` and ``HARNESS_ALLOWED_HOSTS``, and a TLS-terminating proxy in front: docs/deploy.md).
Either way the server runs in a child process given this command's workspace (``HARNESS_HOME``) and brings
the store's schema up to date as it opens it.
"""
from __future__ import annotations

import errno
import os
import socket
import subprocess
import sys

from harness.adapters.base import UserError
from harness.execution.workspace import PROJECT_ROOT, workspace

NAME = "serve"
HELP = "serve the web dashboard over the store (development server, or gunicorn with --production)"


def configure(parser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    parser.add_argument("--reload", action="store_true", help="restart when the code changes (development)")
    parser.add_argument("--production", action="store_true",
                        help="gunicorn with the production settings (HARNESS_SECRET_KEY, HARNESS_ALLOWED_HOSTS)")
    parser.add_argument("--workers", type=int, default=2, help="gunicorn worker processes (default 2)")


def command(args, *django_args: str, settings: str = "webfrontend.settings") -> list[str]:
    """The ``python -m django`` command line with the dashboard settings."""
    return [sys.executable, "-m", "django", *django_args, "--settings", settings]


def environment() -> dict:
    env = dict(os.environ)
    env["HARNESS_HOME"] = str(workspace().home)
    # the project folder on the path even without `pip install -e .`
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(PROJECT_ROOT), env.get("PYTHONPATH", "")) if p)
    return env


def check_port_free(host: str, port: int) -> None:
    """Raise a UserError naming the address when nothing can listen on it (another server holds it, or it is not
    this machine's); the servers alone would report it after their start-up, gunicorn after five seconds of
    retries."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as error:
        raise UserError(f"serve: --host {host}: {error.strerror}") from None
    family, _type, _proto, _name, address = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        # as the servers bind: a port left in TIME_WAIT by a server that just stopped is free to them
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as error:
            hint = " (another server?): choose another --port" if error.errno == errno.EADDRINUSE else ""
            raise UserError(f"serve: cannot listen on {host}:{port}: {error.strerror}{hint}") from None


def run(args) -> int:
    check_port_free(args.host, args.port)
    env = environment()
    settings = "webfrontend.settings_production" if args.production else "webfrontend.settings"
    # the servers bring the store's schema up to date as they open it (harness.store.schema.ensure_schema)
    prepare = [("collectstatic", "--noinput", "--verbosity", "0")] if args.production else []
    for step in prepare:
        done = subprocess.run(command(args, *step, settings=settings), env=env, capture_output=True, text=True)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["failed"])[-1]
            raise UserError(f"serve: {step[0]} failed: {last}")
    if args.production:
        server = [sys.executable, "-m", "gunicorn", "webfrontend.wsgi:application", "--bind",
                  f"{args.host}:{args.port}", "--workers", str(max(1, args.workers)), "--access-logfile", "-",
                  "--env", f"DJANGO_SETTINGS_MODULE={settings}"]
    else:
        server = command(args, "runserver", f"{args.host}:{args.port}", *([] if args.reload else ["--noreload"]))
    print(f"dashboard on http://{args.host}:{args.port}/ ({'gunicorn, production settings' if args.production else 'development server'}; "
          "Ctrl-C stops it)", flush=True)
    try:
        return subprocess.run(server, env=env).returncode
    except KeyboardInterrupt:
        return 0
