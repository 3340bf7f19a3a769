"""The dashboard under hostile input and on real stores: no 500 from a request value, nothing of the settings or
the environment on any error page, bounded memory, a store opened whatever its schema, verdicts that name
what they were computed on and agree with `harness check`.

In-process tests use Django's test client on a throw-away test database; the server tests start the real
`python manage.py runserver` on a temporary workspace, the JUnit test the real CLI on a fake engine.
"""
from __future__ import annotations

import html as htmllib
import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
import tracemalloc
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from harness_process import free_port, stop_session

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO / "tests" / "web"), str(REPO / "tests" / "harness")]

# Django with the dashboard settings (a superset of the store's), as tests/web/conftest.py does; the
# variables are put back afterwards so that programs other tests start keep the settings they expect, and
# a workspace of our own keeps the user's .harness/ untouched when this module configures Django first.
_saved = {k: os.environ.get(k) for k in ("DJANGO_SETTINGS_MODULE", "HARNESS_HOME")}
os.environ["DJANGO_SETTINGS_MODULE"] = "webfrontend.settings"
os.environ.setdefault("HARNESS_HOME", tempfile.mkdtemp(prefix="dashboard-faults-"))
import django  # noqa: E402
from django.conf import settings  # noqa: E402

django.setup()
for _key, _value in _saved.items():
    if _value is None:
        os.environ.pop(_key, None)
    else:
        os.environ[_key] = _value
if "webfrontend" not in settings.INSTALLED_APPS:
    pytest.skip("Django was configured before this module without the dashboard settings "
                "(use DJANGO_SETTINGS_MODULE=webfrontend.settings)", allow_module_level=True)

from dashboard_data import make_store  # noqa: E402
from django.db import connection  # noqa: E402
from django.test import Client, TestCase, override_settings  # noqa: E402

#: the store's database before any test database replaces it (tests/web's session database may be active)
_STORE_NAME = connection.settings_dict["NAME"]
CANARY = "canary-5f1e2d3c4b5a"


@pytest.fixture(scope="module", autouse=True)
def test_database(tmp_path_factory):
    """A fresh test database for this module, unless tests/web's conftest has one up already."""
    from django.test.utils import setup_test_environment, teardown_test_environment

    if connection.settings_dict["NAME"] != _STORE_NAME:
        yield
        return
    try:
        setup_test_environment()
        ours = True
    except RuntimeError:  # set up already by another test folder's fixture
        ours = False
    if connection.vendor == "sqlite":
        connection.settings_dict.setdefault("TEST", {})["NAME"] = str(
            tmp_path_factory.mktemp("faults-store") / "test.sqlite3")
    old_name = connection.creation.create_test_db(verbosity=0, autoclobber=True)
    yield
    connection.creation.destroy_test_db(old_name, verbosity=0)
    if ours:
        teardown_test_environment()


# --- hostile request values ---------------------------------------------------------------------------------

#: values a URL may carry (already percent-encoded where needed)
HOSTILE = {
    "superscript two": "%C2%B2",          # '²': str.isdigit() is True, int() fails
    "arabic-indic one": "%D9%A1",         # '١': str.isdigit() is True, int() reads 1
    "fullwidth five": "%EF%BC%95",
    "beyond SQLite integers": "99999999999999999999",
    "2**63": "9223372036854775808",
    "negative": "-1",
    "zero": "0",
    "empty": "",
    "float": "1.0",
    "leading space": "%201",
    "very long": "x" * 20000,
    "very long digits": "9" * 5000,
    "dot dot": "..",
    "NUL": "%00",
    "NUL inside": "1%002",
}


def leaks(body: bytes) -> list[str]:
    """What of the settings or the environment a response shows."""
    marks = {"canary": CANARY.encode(), "SECRET_KEY value": settings.SECRET_KEY.encode(),
             "settings name": b"SECRET_KEY", "database path": str(settings.DATABASES["default"]["NAME"]).encode(),
             "traceback": b"Traceback", "environment": b"HARNESS_", "debug page": b"You're seeing this error"}
    return [name for name, mark in marks.items() if mark and mark in body]


@override_settings(DEBUG=False)
class HostileInputTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        cls.root = Path(tempfile.mkdtemp(prefix="dashboard-faults-runs-"))
        cls.s = make_store(cls.root)

    @classmethod
    def tearDownClass(cls):
        super().tearDownClass()
        shutil.rmtree(cls.root, ignore_errors=True)

    def setUp(self):
        os.environ["HARNESS_LEAK_CANARY"] = CANARY  # would show on a debug page, with the environment
        self.client = Client(raise_request_exception=False)

    def tearDown(self):
        os.environ.pop("HARNESS_LEAK_CANARY", None)

    def urls(self) -> list[str]:
        s = self.s
        run, m, t = s["inconsistent"].pk, s["ws1"].pk, s["master"].pk
        series = s["inconsistent"].series.first().pk
        ids = ["/runs/{v}/", "/runs/{v}/consistency/", f"/m/{{v}}/t/{t}/", f"/m/{m}/t/{{v}}/",
               "/runs/{v}/plots.json", "/runs/{v}/consistency/plots.json",
               "/history/{v}/contact_models/hertz/impact/", "/history/{v}/contact_models/hertz/impact/plots.json",
               "/sweeps/{v}/packing/settle/x.json"]
        paths = ["/testcases/{v}/", f"/m/{m}/t/{t}/f/{{v}}/", f"/runs/{run}/files/{{v}}", f"/history/{t}/{{v}}/",
                 f"/history/{t}/{{v}}/plots.json", "/sweeps/1/{v}/x.json", "/sweeps/1/packing/{v}.json",
                 "/testcases/contact_models/{v}/hertz/", f"/runs/{run}/files/post/{{v}}/torque.csv"]
        queries = ["/?machine={v}", "/?mode={v}", f"/m/{m}/t/{t}/?show={{v}}", f"/m/{m}/t/{t}/?mode={{v}}",
                   "/compare/?run={v}", f"/compare/?run={run},{{v}}", f"/compare/?run={run}&run={{v}}",
                   "/compare/plots.json?run={v}", f"/compare/plots.json?run={run},{{v}}",
                   f"/compare/plots.json?run={run}&run={{v}}", f"/history/{t}/contact_models/hertz/impact/?machine={{v}}",
                   f"/history/{t}/contact_models/hertz/impact/plots.json?machine={{v}}", "/junit.xml?machine={v}",
                   "/regressions/?machine={v}", "/regressions/?target={v}", "/regressions/?k={v}",
                   "/junit.xml?target={v}", "/accounts/login/?next={v}", "/testcases/contact_models/hertz/impact/?page={v}",
                   f"/history/{t}/contact_models/hertz/impact/?page={{v}}",
                   "/admin/harness/override/{v}/change/", "/admin/harness/override/?run__id__exact={v}",
                   "/builds/compare/?a={v}&b={v}", f"/builds/compare/?a={s['new_build'].pk}&b={{v}}",
                   "/builds/compare/?a={v}", "/matrix/?machine={v}", "/matrix/?target={v}",
                   f"/matrix/?target={t}&target={{v}}", "/matrix/?k={v}", "/matrix.json?target={v}",
                   "/matrix.json?k={v}"]
        # search and filters of the run lists, alone and twice, on every list that takes them
        for page in ("/", f"/m/{m}/t/{t}/", f"/m/{m}/t/{t}/f/contact_models/hooke/impact/",
                     "/testcases/contact_models/hertz/impact/"):
            for name in ("q", "commit", "build", "state", "reason"):
                queries += [f"{page}?{name}={{v}}", f"{page}?{name}=1&{name}={{v}}"]
            queries.append(f"{page}?q={{v}}&commit={{v}}&build={{v}}&state={{v}}&reason={{v}}&page={{v}}")
        return ids + paths + queries

    def test_no_hostile_value_gives_a_500_or_shows_the_environment(self):
        self.client.force_login(self.s["user"])  # reaches the override form and (as non-staff) the admin login
        bad, statuses = [], {}
        for name, value in HOSTILE.items():
            for url in self.urls():
                response = self.client.get(url.format(v=value))
                body = b"" if response.streaming else response.content
                statuses[response.status_code] = statuses.get(response.status_code, 0) + 1
                if response.status_code >= 500 or leaks(body):
                    bad.append(f"{name}: {url.format(v=value)[:80]} -> {response.status_code} {leaks(body)}")
            for data in ({"reason": "ok", "quantity": value}, {"reason": value or "x", "next": value}):
                response = self.client.post(f"/runs/{self.s['inconsistent'].pk}/override/",
                                            {k: v.replace("%00", "\x00") for k, v in data.items()})
                if response.status_code >= 500 or leaks(response.content):
                    bad.append(f"{name}: override {data} -> {response.status_code}")
        assert bad == [], f"{len(bad)} bad answers, e.g. {bad[:5]}"
        assert set(statuses) <= {200, 301, 302, 400, 404}, statuses
        assert statuses[400] > 100 and statuses[404] > 100  # most hostile values are refused, not served

    def test_a_bad_parameter_is_a_400_naming_it(self):
        series = self.s["reference"].series.get(kind="thermo").pk
        for url, message in [
                ("/?machine=%C2%B2", "machine: '²' is not an id (a whole number from 1 to 9223372036854775807"),
                ("/?machine=%D9%A1", "machine: '١' is not an id"),
                ("/junit.xml?target=99999999999999999999", "target: '99999999999999999999' is not an id"),
                ("/?machine=1&machine=2", "machine: given 2 times; give it once"),
                ("/?mode=fancy", "mode: 'fancy' is not one of state, consistency"),
                ("/regressions/?k=a%00b", "k: 'a\\x00b' holds control characters"),
                ("/compare/plots.json?run=1", "run: two or more runs are compared"),
                (f"/builds/compare/?a={self.s['new_build'].pk}", "a and b: name both builds to compare"),
                ("/?commit=%C2%B2", "commit: '²' is not the start of a commit id"),
                ("/?commit=" + "a" * 41, "is not the start of a commit id (1 to 40 hex digits"),
                ("/testcases/contact_models/hertz/impact/?build=-1", "build: '-1' is not an id"),
                (f"/m/{self.s['ws1'].pk}/t/{self.s['master'].pk}/?state=%00", "state: '\\x00' is not one of"),
                ("/?reason=", None), ("/?q=" + "x" * 201, "q: longer than 200 characters (201)"),
                ("/?q=a%00b", "q: 'a\\x00b' holds control characters")]:
            if message is None:  # blank: no filter
                assert self.client.get(url).status_code == 200, url
                continue
            response = self.client.get(url)
            assert response.status_code == 400, url
            text = htmllib.unescape(response.content.decode())
            assert message in text, (url, text[-600:])

    def test_path_values_the_store_cannot_hold_are_404(self):
        run = self.s["reference"].pk
        for url in ("/runs/99999999999999999999/", "/runs/9223372036854775808/consistency/", "/runs/0/",
                    "/runs/99999999999999999999/plots.json", f"/runs/{run}/files/a%00b",
                    f"/runs/{run}/files/{'x' * 5000}", f"/runs/{run}/files/post/../../secret",
                    "/testcases/contact_models/../packing/settle/", "/testcases/a%00b/"):
            response = self.client.get(url)
            assert response.status_code == 404, url
            assert b"Not found (404)" in response.content and not leaks(response.content)
        self.assertEqual(self.client.get(f"/runs/{9223372036854775807}/").status_code, 404)  # the largest id

    def test_requests_django_refuses_get_the_dashboards_400(self):
        for response in (self.client.get("/compare/?" + "&".join(f"run={i}" for i in range(1, 1500))),  # > 1000 fields
                         self.client.get("/", HTTP_HOST="evil.example.org")):                             # unknown host
            assert response.status_code == 400
            assert b"Bad request (400)" in response.content and not leaks(response.content)

    def test_error_pages_are_the_dashboards_own(self):
        response = self.client.get("/no/such/page/")
        assert response.status_code == 404
        html = response.content.decode()
        assert "Nothing at <code>/no/such/page/</code>" in html and "urlpatterns" not in html


class TestDebugSetting:
    """DEBUG is off unless HARNESS_DEBUG=1 (subprocesses: the settings module is read once per process)."""

    @pytest.mark.parametrize("value, expected", [(None, "False"), ("1", "True"), ("0", "False"), ("true", "False"),
                                                 ("yes", "False")])
    def test_debug_only_when_asked_for(self, tmp_path, value, expected):
        env = server_env(tmp_path)
        if value is not None:
            env["HARNESS_DEBUG"] = value
        code = ("import django; django.setup(); from django.conf import settings; "
                "print(settings.DEBUG, 'localhost' in settings.ALLOWED_HOSTS)")
        done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 0, done.stderr
        assert done.stdout.split() == [expected, "True"]



# --- bounded memory -----------------------------------------------------------------------------------------

@override_settings(DEBUG=False)
class BoundedPagesTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        from harness.store.models import Build, Machine, Run, Target
        from harness.store.models import TestCase as Case

        cls.root = Path(tempfile.mkdtemp(prefix="dashboard-faults-big-"))
        machine = Machine.objects.create(name="big")
        target = Target.objects.create(name="dem", definition={"engine": "dem"})
        cls.build = Build.objects.create(target=target, machine=machine, revision="HEAD", commit="e" * 40,
                                         definition_hash="d", status="complete", current=True,
                                         log="make: compiling\n" * 150_000 + "make: *** [fedora] Error 1\n")
        case = Case.objects.create(path="big/case")
        text = "Step Atoms KinEng\n" + "1 100 1.0e-3\n" * 30_000  # 390 kB
        runs = []
        for i in range(450):
            folder = cls.root / f"r{i}"
            if i < 60:  # run folders for the comparison: a big log, console output and record each
                folder.mkdir()
                for name in ("log.dem", "stdout.txt", "run.json"):
                    (folder / name).write_text(text)
            runs.append(Run(machine=machine, target=target, build=cls.build, testcase=case, name=f"r{i:03d}",
                            testcase_hash=f"{i:064x}", state="post_processed", folder=str(folder),
                            timing={"pair": 1.0, "total": 1.5}, wall_time=1.5))
        Run.objects.bulk_create(runs)
        cls.ids = list(Run.objects.filter(machine=machine).order_by("name").values_list("pk", flat=True))

    @classmethod
    def tearDownClass(cls):
        super().tearDownClass()
        shutil.rmtree(cls.root, ignore_errors=True)

    def test_compare_caps_the_number_of_runs_and_says_so(self):
        limit = settings.DASHBOARD_COMPARE_LIMIT
        assert limit == 50
        page = self.client.get("/compare/?run=" + ",".join(map(str, self.ids[:limit])))
        assert page.status_code == 200
        assert f"Up to {limit} runs at once" in page.content.decode()
        for url in ("/compare/?run=" + ",".join(map(str, self.ids[:limit + 1])),
                    "/compare/?" + "&".join(f"run={i}" for i in self.ids),
                    "/compare/plots.json?run=" + ",".join(map(str, self.ids[:limit + 1]))):
            response = self.client.get(url)
            assert response.status_code == 400
            assert f"run: at most {limit} runs at once (got " in response.content.decode()
        # the same run named twice is one run
        assert self.client.get("/compare/?run=" + ",".join([str(self.ids[0])] * (limit + 5))).status_code == 200

    def test_compare_reads_no_run_files_for_many_runs(self):
        url = "/compare/?run=" + ",".join(map(str, self.ids[:40]))
        self.client.get(url)  # warm: templates compiled, modules imported
        tracemalloc.start()
        try:
            response = self.client.get(url)
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert response.status_code == 200 and "Comparison of 40 runs" in response.content.decode()
        # reading the 40 folders' three 390 kB files would take more than 40 x 3 x 390 kB = 47 MB
        assert peak < 10e6, f"peak {peak / 1e6:.1f} MB"

    def test_run_lists_are_paged(self):
        html = self.client.get("/testcases/big/case/").content.decode()
        assert html.count('name="run" value=') == settings.DASHBOARD_LIST_PAGE_SIZE
        assert "runs 1-200 of 450" in html and "page 1 of 3" in html
        last = self.client.get("/testcases/big/case/?page=3").content.decode()
        assert last.count('name="run" value=') == 50 and 'value="%d"' % self.ids[-1] in last
        beyond = self.client.get("/testcases/big/case/?page=99").content.decode()  # the last page
        assert beyond.count('name="run" value=') == 50

    def test_run_page_shows_the_end_of_a_long_build_log(self):
        response = self.client.get(f"/runs/{self.ids[100]}/")  # a run without files of its own to show
        html = response.content.decode()
        assert "make: *** [fedora] Error 1" in html
        assert f"last {settings.DASHBOARD_TEXT_LIMIT} of {len(self.build.log)} characters" in html
        assert len(response.content) < 2 * settings.DASHBOARD_TEXT_LIMIT + 100_000


# --- real servers on real stores ----------------------------------------------------------------------------

def server_env(tmp_path, **extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("DJANGO_SETTINGS_MODULE", "HARNESS_DATABASE_URL", "HARNESS_DEBUG", "HARNESS_HOME")}
    env.update({"HARNESS_HOME": str(tmp_path / "home"), "PYTHONPATH": str(REPO),
                "DJANGO_SETTINGS_MODULE": "webfrontend.settings", **extra})
    return env


class Server:
    """`python manage.py runserver` in its own session (the autoreloader's child goes with it)."""

    def __init__(self, tmp_path, *args, **env):
        self.port = free_port()
        self.log = tmp_path / f"server-{self.port}.log"
        self.process = subprocess.Popen([sys.executable, "manage.py", "runserver", f"127.0.0.1:{self.port}", *args],
                                        cwd=REPO, env=server_env(tmp_path, **env), stdout=self.log.open("w"),
                                        stderr=subprocess.STDOUT, start_new_session=True)

    def get(self, path: str, timeout: float = 90) -> tuple[int, bytes]:
        deadline = time.monotonic() + timeout
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{self.port}{path}", timeout=10) as response:
                    return response.status, response.read()
            except urllib.error.HTTPError as error:
                return error.code, error.read()
            except OSError:
                assert self.process.poll() is None, self.output()
                assert time.monotonic() < deadline, f"no answer within {timeout} s: {self.output()}"
                time.sleep(0.3)

    def output(self) -> str:
        return self.log.read_text()

    def stop(self):
        stop_session(self.process)


@pytest.fixture
def servers():
    started = []
    yield lambda *a, **k: started.append(Server(*a, **k)) or started[-1]
    for server in started:
        server.stop()


def python(tmp_path, code: str, settings_module="webfrontend.settings", **env) -> str:
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300,
                          env=server_env(tmp_path, DJANGO_SETTINGS_MODULE=settings_module, **env))
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def applied_migrations(home: Path) -> set[str]:
    with sqlite3.connect(home / "harness.sqlite3") as db:
        return {f"{app}.{name}" for app, name in db.execute("SELECT app, name FROM django_migrations")}


def migration_names() -> set[str]:
    out = set()
    for app, folder in (("harness", REPO / "harness" / "migrations"),):
        out |= {f"{app}.{p.stem}" for p in folder.glob("0*.py")}
    return out


def test_runserver_as_the_readme_says_on_a_fresh_workspace(tmp_path, servers):
    server = servers(tmp_path)  # verbatim: `python manage.py runserver` (autoreloader and all)
    status, body = server.get("/")
    assert status == 200 and b"The store holds no runs yet" in body
    status, css = server.get("/static/webfrontend/style.css")  # DEBUG is off: whitenoise serves it
    assert status == 200 and b".bar" in css
    assert migration_names() <= applied_migrations(tmp_path / "home")
    assert "unapplied migration" not in server.output()


OLDER_STORE = """
import django
django.setup()
from django.core.management import call_command
from django.db import connection
from django.db.migrations.executor import MigrationExecutor
call_command("migrate", "harness", "0002", verbosity=0)  # what the CLI of two versions ago made
apps = MigrationExecutor(connection).loader.project_state(("harness", "0002_build_environment")).apps
get = lambda name: apps.get_model("harness", name)
machine = get("Machine").objects.create(name="old-box")
target = get("Target").objects.create(name="dem", definition={"engine": "dem"})
old = get("Build").objects.create(target=target, machine=machine, revision="HEAD~1", commit="9" * 40,
                                  definition_hash="x", status="complete")
new = get("Build").objects.create(target=target, machine=machine, revision="HEAD", commit="d" * 40,
                                  definition_hash="x", status="complete")
case = get("TestCase").objects.create(path="analytic/free_fall")
for build, state in ((old, "outdated"), (new, "post_processed")):
    get("Run").objects.create(machine=machine, target=target, build=build, testcase=case, name="serial",
                              state=state, wall_time=1.0)
"""


def test_runserver_migrates_an_older_store_the_cli_made(tmp_path, servers):
    python(tmp_path, OLDER_STORE, settings_module="harness.settings")
    assert "harness.0003_provenance" not in applied_migrations(tmp_path / "home")
    server = servers(tmp_path, "--noreload")
    status, body = server.get("/")
    html = body.decode()
    assert status == 200, html
    page = re.sub(r"\s+", " ", html)
    assert "<h2>machine old-box</h2>" in page and '<span class="count successful">1</span>' in page, page
    # the newest build, marked current by 0003; the outdated run of the older build is not counted
    assert '<code class="revision">dddddddddd</code></a> <span class="note">HEAD</span>' in page, page
    assert "+1 older" in page, page
    assert migration_names() <= applied_migrations(tmp_path / "home")


def test_two_servers_opening_one_new_store_migrate_it_once(tmp_path, servers):
    first, second = servers(tmp_path, "--noreload"), servers(tmp_path, "--noreload")
    for server in (first, second):
        status, body = server.get("/")
        assert status == 200 and b"The store holds no runs yet" in body, server.output()
        assert "Traceback" not in server.output() and "already exists" not in server.output()
    assert migration_names() <= applied_migrations(tmp_path / "home")


def test_createsuperuser_first_on_a_fresh_workspace(tmp_path):
    done = subprocess.run([sys.executable, "manage.py", "createsuperuser", "--noinput", "--username", "reviewer",
                           "--email", "reviewer@example.org"], cwd=REPO, capture_output=True, text=True, timeout=300,
                          env=server_env(tmp_path, DJANGO_SUPERUSER_PASSWORD="pw-for-tests-only-7"))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "unapplied migration" not in done.stdout + done.stderr
    with sqlite3.connect(tmp_path / "home" / "harness.sqlite3") as db:
        assert db.execute("SELECT username, is_superuser FROM auth_user").fetchall() == [("reviewer", 1)]


ONE_RUN = """
import django
django.setup()
from django.core.management import call_command
call_command("migrate", verbosity=0)
from harness.store.models import Build, Machine, Run, Target, TestCase
machine = Machine.objects.create(name="ws")
target = Target.objects.create(name="dem", definition={})
build = Build.objects.create(target=target, machine=machine, revision="HEAD", commit="f" * 40, definition_hash="x",
                             status="complete", current=True)
print(Run.objects.create(machine=machine, target=target, build=build, testcase=TestCase.objects.create(path="a"),
                         name="serial", state="post_processed").pk)
"""


def test_a_server_error_shows_nothing_of_the_settings_or_the_environment(tmp_path, servers):
    # the measured leak: HARNESS_DATABASE_URL in the environment, shown by Django's debug page; here the
    # canary is a folder of the database's path, so the URL, the settings and the path all carry it
    database = tmp_path / "home" / CANARY / "harness.sqlite3"
    database.parent.mkdir(parents=True)
    url = {"HARNESS_DATABASE_URL": f"sqlite:///{database}"}
    run = int(python(tmp_path, ONE_RUN, **url))
    with sqlite3.connect(database) as db:  # a store broken under the server: a real 500
        db.execute("ALTER TABLE harness_series RENAME TO harness_series_gone")
    server = servers(tmp_path, "--noreload", **url)
    status, body = server.get(f"/runs/{run}/")
    assert status == 500
    assert b"Server error (500)" in body
    assert leaks(body) == [] and str(tmp_path).encode() not in body
    assert "no such table: harness_series" in server.output()  # the details go to the server's log
    status, body = server.get("/")
    assert status == 200  # the rest of the dashboard still works

    # the same request with DEBUG asked for shows the environment: the checks above can see a leak
    debug = servers(tmp_path, "--noreload", HARNESS_DEBUG="1", **url)
    status, body = debug.get(f"/runs/{run}/")
    assert status == 500 and CANARY.encode() in body


# --- verdicts: what they were computed on, and the same in the dashboard and `harness check` -----------------

@override_settings(DEBUG=False)
class ProvenanceTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        cls.root = Path(tempfile.mkdtemp(prefix="dashboard-faults-prov-"))
        cls.s = make_store(cls.root)

    @classmethod
    def tearDownClass(cls):
        super().tearDownClass()
        shutil.rmtree(cls.root, ignore_errors=True)

    def test_every_verdict_names_commit_test_case_and_reference(self):
        s = self.s
        run = s["inconsistent"]
        facts = ["commit <code>cccccccccc</code>", "test case <code>1e1e1e1e1e</code>", "<code>aaaaaaaaaa</code>"]
        pages = {
            "run page": f"/runs/{run.pk}/",
            "run list": f"/m/{s['ws1'].pk}/t/{s['master'].pk}/f/contact_models/hertz/impact/",
            "all runs of a test case": "/testcases/contact_models/hertz/impact/",
            "history": f"/history/{s['master'].pk}/contact_models/hertz/impact/",
            "comparison": f"/compare/?run={run.pk}&run={s['older'].pk}",
            "consistency": f"/runs/{run.pk}/consistency/",
        }
        for name, url in pages.items():
            html = self.client.get(url).content.decode()
            for fact in facts:
                assert fact in html, (name, fact)
        html = self.client.get(f"/runs/{run.pk}/").content.decode()
        assert "Verdict: failed</strong>: ke: inconsistent, C = 0.8257, first bad step 1000" in html

    def test_reference_of_other_content_is_flagged(self):
        from harness.store.models import Run

        Run.objects.filter(pk=self.s["reference"].pk).update(testcase_hash="77" * 32)
        html = self.client.get(f"/runs/{self.s['inconsistent'].pk}/consistency/").content.decode()
        assert "The reference run ran other test case content (7777777777, this run 1e1e1e1e1e)" in html

    def test_junit_of_several_machines_asks_for_one(self):
        from dashboard_data import add_bulk_runs

        from harness.store.models import Machine

        other = Machine.objects.create(name="cluster7")
        add_bulk_runs(2, other, self.s["master"], self.s["new_build"])
        response = self.client.get("/junit.xml")
        assert response.status_code == 400
        html = response.content.decode()
        assert "machine: the store holds runs of 2 machines and a JUnit report is per machine" in html
        assert f'href="/junit.xml?machine={other.pk}"' in html
        assert self.client.get(f"/junit.xml?machine={other.pk}").status_code == 200


SCENE = [{"command": "create", "heights": [1.0, "${H}"]}, {"command": "run", "steps": 300, "every": 20},
         {"command": "write", "file": "post/state.txt", "text": "restitution 0.9 bounces 3\n"}]

DASHBOARD_JUNIT = """
import json, sys, django
MODE = "{mode}"
django.setup()
from harness.store.schema import ensure_schema
ensure_schema()  # what a server does when it starts
from django.test import Client
from harness.store.models import Machine, Override, Run, Target
if MODE == "override":
    for run in Run.objects.filter(target__name="bad", build__current=True):
        Override.objects.create(run=run, quantity="", reason="gravity changed on purpose")
    sys.exit(0)
machine = Machine.objects.get(name="m1").pk
client = Client()
out = {}
for key, query in (("bad", {"machine": machine, "target": Target.objects.get(name="bad").pk}),
                   ("all", {"machine": machine})):
    response = client.get("/junit.xml", query)
    assert response.status_code == 200, response.status_code
    out[key] = response.content.decode()
print(json.dumps(out))
"""


def test_dashboard_junit_is_what_harness_check_writes(tmp_path):
    from harness_support import commit_files, fake_engine_source, git_repo

    repo = git_repo(tmp_path / "repo")
    runs = [{"name": "fall", "script": "scene.json", "variables": {"H": 2.0}, "data": {"textfiles": ["post/state.txt"]}},
            {"name": "short", "script": "scene.json", "variables": {"H": 0.5}}]
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81),
                        "cases/fall/scene.json": json.dumps(SCENE),
                        "cases/fall/run.config": json.dumps({"runs": runs})}, "v1", tag="v1")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81 * 1.3)}, "v2", tag="v2")
    targets = tmp_path / "targets"
    targets.mkdir()
    common = {"repository": str(repo.working_tree_dir), "testcases_revision": "v1", "testcases": ["cases/fall"]}
    (targets / "ref.json").write_text(json.dumps({**common, "revision": "v1"}))
    (targets / "bad.json").write_text(json.dumps({**common, "revision": "v2", "reference": "ref"}))

    def cli(*args) -> int:
        done = subprocess.run([sys.executable, "-m", "harness.cli", "--home", str(tmp_path / "home"), "--machine",
                               "m1", "--targets", str(targets), *args], cwd=REPO, capture_output=True, text=True,
                              timeout=600, env=server_env(tmp_path, DJANGO_SETTINGS_MODULE="harness.settings"))
        assert "Traceback" not in done.stderr, done.stderr
        return done.returncode

    assert cli("run", "ref", "bad") == 0
    for round_ in ("inconsistent", "overruled"):
        assert cli("check", "bad", "--junit", str(tmp_path / "bad.xml")) == (1 if round_ == "inconsistent" else 0)
        assert cli("check", "--junit", str(tmp_path / "all.xml")) == (1 if round_ == "inconsistent" else 0)
        dashboard = json.loads(python(tmp_path, DASHBOARD_JUNIT.replace("{mode}", "report")))
        cli_bad = (tmp_path / "bad.xml").read_text()
        assert dashboard["bad"] == cli_bad, round_
        assert dashboard["all"] == (tmp_path / "all.xml").read_text(), round_
        fall = re.search(r'<testcase name="fall".*?</testcase>', cli_bad, re.S).group(0)
        if round_ == "inconsistent":
            assert 'type="inconsistent"' in fall and "ke: inconsistent, C = " in fall
            python(tmp_path, DASHBOARD_JUNIT.replace("{mode}", "override"))
        else:
            assert "<failure" not in fall and "someone: gravity changed on purpose - overruled" in fall
        assert re.search(r"bad at [0-9a-f]{10}, test case [0-9a-f]{10}; reference ref at [0-9a-f]{10}", fall)
