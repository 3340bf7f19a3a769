"""Production settings: ``manage.py check --deploy --settings webfrontend.settings_production`` is clean.

Needs ``HARNESS_SECRET_KEY`` (50+ random characters) and ``HARNESS_ALLOWED_HOSTS`` (comma separated);
serve behind a TLS-terminating proxy that sets ``X-Forwarded-Proto``; run ``collectstatic`` once.
"""
import os

from django.core.exceptions import ImproperlyConfigured

from webfrontend.settings import *  # noqa: F401,F403

DEBUG = False
SECRET_KEY = os.environ.get("HARNESS_SECRET_KEY", "")
if len(SECRET_KEY) < 50 or SECRET_KEY.startswith("dev-only"):
    raise ImproperlyConfigured("HARNESS_SECRET_KEY: set 50 or more random characters for production")
ALLOWED_HOSTS = [h for h in os.environ.get("HARNESS_ALLOWED_HOSTS", "localhost").split(",") if h]

WHITENOISE_USE_FINDERS = False
STORAGES = {
    "default": {"BACKEND": "django.core.files.storage.FileSystemStorage"},
    "staticfiles": {"BACKEND": "whitenoise.storage.CompressedManifestStaticFilesStorage"},
}

SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
SECURE_SSL_REDIRECT = True
SESSION_COOKIE_SECURE = True
CSRF_COOKIE_SECURE = True
SECURE_HSTS_SECONDS = 31_536_000
SECURE_HSTS_INCLUDE_SUBDOMAINS = True
SECURE_HSTS_PRELOAD = True
SECURE_CONTENT_TYPE_NOSNIFF = True
X_FRAME_OPTIONS = "DENY"
