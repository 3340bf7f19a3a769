"""Production settings pass Django's deployment checks; `harness serve` serves the dashboard."""
from __future__ import annotations

import argparse
import os
import secrets
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request

import pytest

from harness_process import free_port, stop_session

from harness.commands import serve
from harness.execution.workspace import PROJECT_ROOT


def env_for(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("DJANGO_SETTINGS_MODULE", "HARNESS_DATABASE_URL")}
    env.update(HARNESS_HOME=str(tmp_path / "home"), PYTHONPATH=str(PROJECT_ROOT), **extra)
    return env


def manage(tmp_path, *args, **extra):
    return subprocess.run([sys.executable, "manage.py", *args], cwd=PROJECT_ROOT, capture_output=True,
                          text=True, env=env_for(tmp_path, **extra), timeout=120)


def test_check_deploy_is_clean(tmp_path):
    done = manage(tmp_path, "check", "--deploy", "--fail-level", "WARNING",
                  "--settings", "webfrontend.settings_production",
                  HARNESS_SECRET_KEY=secrets.token_urlsafe(64), HARNESS_ALLOWED_HOSTS="harness.example.org")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "System check identified no issues" in done.stdout


def test_production_refuses_the_development_key(tmp_path):
    done = manage(tmp_path, "check", "--settings", "webfrontend.settings_production")
    assert done.returncode != 0
    assert "HARNESS_SECRET_KEY: set 50 or more random characters for production" in done.stderr


def test_harness_serve_serves_the_dashboard(tmp_path):
    parser = argparse.ArgumentParser()
    serve.configure(parser)
    assert serve.NAME == "serve" and serve.HELP
    port = free_port()
    code = ("import argparse, sys; from harness.commands import serve; p = argparse.ArgumentParser(); "
            f"serve.configure(p); sys.exit(serve.run(p.parse_args(['--port', '{port}'])))")
    process = subprocess.Popen([sys.executable, "-c", code], cwd=tmp_path, env=env_for(tmp_path),
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        body = None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and body is None:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as response:
                    body = response.read().decode()
                    css = urllib.request.urlopen(f"http://127.0.0.1:{port}/static/webfrontend/style.css",
                                                 timeout=5).read()
            except OSError:
                assert process.poll() is None, process.stdout.read().decode()
                time.sleep(0.3)
        assert body is not None, "server did not answer within 60 s"
        assert "The store holds no runs yet" in body
        assert b".bar" in css
        assert (tmp_path / "home" / "harness.sqlite3").is_file()  # migrated before serving
    finally:
        stop_session(process)


@pytest.mark.parametrize("production", [False, True])
def test_harness_serve_names_a_port_in_use_at_once(tmp_path, production):
    port = free_port()
    env = env_for(tmp_path, HARNESS_SECRET_KEY=secrets.token_urlsafe(64), HARNESS_ALLOWED_HOSTS="harness.example.org")
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", port))
        holder.listen()
        done = subprocess.run([sys.executable, "-m", "harness.cli", "serve", "--port", str(port),
                               *(["--production"] if production else [])],
                              cwd=PROJECT_ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert done.stderr.strip().splitlines()[-1].endswith(
        f"serve: cannot listen on 127.0.0.1:{port}: Address already in use (another server?): choose another --port")
    assert not (tmp_path / "home" / "static").exists()   # stopped before collecting anything


PRODUCTION_CLIENT = """
import re, django
django.setup()
from django.core.management import call_command
call_command("migrate", verbosity=0)
from django.test import Client
client = Client(HTTP_HOST="harness.example.org")
insecure = client.get("/")
page = client.get("/", secure=True)
css = re.search(r'href="(/static/webfrontend/style\\.[0-9a-f]+\\.css)"', page.content.decode()).group(1)
response = client.get(css, secure=True)
print(insecure.status_code, page.status_code, page["Strict-Transport-Security"], css, response.status_code,
      b"".join(response.streaming_content).count(b".bar"), sep="|")
"""


def test_production_serves_hashed_static_files_over_https(tmp_path):
    extra = dict(HARNESS_SECRET_KEY=secrets.token_urlsafe(64), HARNESS_ALLOWED_HOSTS="harness.example.org",
                 DJANGO_SETTINGS_MODULE="webfrontend.settings_production")
    assert manage(tmp_path, "collectstatic", "--noinput", **extra).returncode == 0
    done = subprocess.run([sys.executable, "-c", PRODUCTION_CLIENT], cwd=PROJECT_ROOT, capture_output=True,
                          text=True, env=env_for(tmp_path, **extra), timeout=120)
    assert done.returncode == 0, done.stderr
    insecure, page, hsts, css, css_status, bars = done.stdout.strip().split("|")
    assert (insecure, page, css_status) == ("301", "200", "200")  # http is redirected to https
    assert hsts.startswith("max-age=31536000")
    assert int(bars) >= 1


def test_harness_serve_production_runs_gunicorn_with_debug_off(tmp_path):
    port = free_port()
    env = env_for(tmp_path, HARNESS_SECRET_KEY=secrets.token_urlsafe(64), HARNESS_ALLOWED_HOSTS="harness.example.org")
    env.pop("HARNESS_HOME")  # the workspace comes from --home, as a user gives it
    command = [sys.executable, "-m", "harness.cli", "--home", str(tmp_path / "prod-home"), "serve", "--production",
               "--port", str(port), "--workers", "2"]
    process = subprocess.Popen(command, cwd=PROJECT_ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               start_new_session=True)

    def get(path):
        request = urllib.request.Request(f"http://127.0.0.1:{port}{path}",
                                         headers={"Host": "harness.example.org", "X-Forwarded-Proto": "https"})
        try:
            with urllib.request.urlopen(request, timeout=5) as response:
                return response.status, response.headers, response.read().decode()
        except urllib.error.HTTPError as error:
            return error.code, error.headers, error.read().decode()

    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                status, headers, body = get("/")
                break
            except OSError:
                assert process.poll() is None, process.stdout.read().decode()
                assert time.monotonic() < deadline, "gunicorn did not answer within 90 s"
                time.sleep(0.3)
        assert status == 200 and "gunicorn" in headers.get("Server", "")
        assert headers["Strict-Transport-Security"].startswith("max-age=31536000")
        missing_status, _headers, missing = get("/runs/999999/")
        assert missing_status == 404 and "Traceback" not in missing and "SECRET" not in missing
        assert (tmp_path / "prod-home" / "harness.sqlite3").is_file()   # the --home workspace, migrated
        assert (tmp_path / "prod-home" / "static" / "staticfiles.json").is_file()   # collected, hashed
    finally:
        stop_session(process)
