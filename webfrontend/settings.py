"""Settings of the dashboard: the store settings plus sessions, auth views, static files.

``python manage.py runserver`` serves it; whitenoise serves the static files in development and production.
DEBUG is off unless ``HARNESS_DEBUG=1``: Django's debug pages show settings and the process environment
(a database password in ``HARNESS_DATABASE_URL``) to whoever makes a page fail.
"""
import os

from harness.execution.workspace import workspace
from harness.settings import *  # noqa: F401,F403  (the same store the CLI writes)
from harness.settings import INSTALLED_APPS as _STORE_APPS

DEBUG = os.environ.get("HARNESS_DEBUG", "") == "1"
ALLOWED_HOSTS = ["127.0.0.1", "localhost", "[::1]", "testserver"] + [
    h for h in os.environ.get("HARNESS_ALLOWED_HOSTS", "").split(",") if h]

INSTALLED_APPS = [
    # first: its runserver and createsuperuser bring the store's schema up to date before they start
    # (webfrontend/management/commands), and its 400/404/500 templates win
    "webfrontend",
] + list(_STORE_APPS) + [
    "django.contrib.admin",
    "django.contrib.sessions",
    "django.contrib.messages",
    # before staticfiles: runserver then leaves static files to whitenoise, as in production
    "whitenoise.runserver_nostatic",
    "django.contrib.staticfiles",
]

MIDDLEWARE = [
    "django.middleware.security.SecurityMiddleware",
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
]

ROOT_URLCONF = "webfrontend.urls"
WSGI_APPLICATION = "webfrontend.wsgi.application"

TEMPLATES = [{
    "BACKEND": "django.template.backends.django.DjangoTemplates",
    "DIRS": [],
    "APP_DIRS": True,
    "OPTIONS": {"context_processors": [
        "django.template.context_processors.request",
        "django.contrib.auth.context_processors.auth",
        "django.contrib.messages.context_processors.messages",
    ]},
}]

STATIC_URL = "static/"
STATIC_ROOT = str(workspace().home / "static")
# whitenoise reads STATIC_ROOT at start and warns on every start of a fresh workspace when it is missing;
# collectstatic fills it for production
os.makedirs(STATIC_ROOT, exist_ok=True)
# whitenoise serves the app's static files straight from the finders, with DEBUG off too (no collectstatic
# needed on a development machine; production collects them, settings_production)
WHITENOISE_USE_FINDERS = True

# With DEBUG off Django logs a failing request nowhere by default (its console handler needs DEBUG): the
# traceback goes to the server's stderr, never to the page.
LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "handlers": {"stderr": {"class": "logging.StreamHandler"}},
    "loggers": {"django.request": {"handlers": ["stderr"], "level": "ERROR", "propagate": False}},
}

LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "overview"
LOGOUT_REDIRECT_URL = "overview"

#: bytes of a log or output file shown on a page (the whole file stays downloadable)
DASHBOARD_TEXT_LIMIT = int(os.environ.get("HARNESS_TEXT_LIMIT", 400_000))
#: runs one comparison shows at most (the page says so; more is a 400 that names the limit)
DASHBOARD_COMPARE_LIMIT = 50
#: rows of a run list per page
DASHBOARD_LIST_PAGE_SIZE = 200
