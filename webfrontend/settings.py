"""Settings of the dashboard in development: the store settings plus sessions, auth views, static files.

``python manage.py runserver`` serves it; whitenoise serves the static files in development and production.
"""
import os

from harness.workspace import workspace
from harness.settings import *  # noqa: F401,F403  (the same store the CLI writes)
from harness.settings import INSTALLED_APPS as _STORE_APPS

DEBUG = os.environ.get("HARNESS_DEBUG", "1") == "1"
ALLOWED_HOSTS = ["127.0.0.1", "localhost", "[::1]", "testserver"] + [
    h for h in os.environ.get("HARNESS_ALLOWED_HOSTS", "").split(",") if h]

INSTALLED_APPS = list(_STORE_APPS) + [
    "django.contrib.admin",
    "django.contrib.sessions",
    "django.contrib.messages",
    # before staticfiles: runserver then leaves static files to whitenoise, as in production
    "whitenoise.runserver_nostatic",
    "django.contrib.staticfiles",
    "webfrontend",
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
WHITENOISE_USE_FINDERS = True

LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "overview"
LOGOUT_REDIRECT_URL = "overview"

#: bytes of a log or output file shown on a page (the whole file stays downloadable)
DASHBOARD_TEXT_LIMIT = int(os.environ.get("HARNESS_TEXT_LIMIT", 400_000))
