"""WSGI entry point (production: DJANGO_SETTINGS_MODULE=webfrontend.settings_production).

The store's schema is brought up to date before the first request (harness.store.schema: the embedded SQLite
store is migrated under a lock; another database with pending migrations stops the start with a message
naming ``python manage.py migrate``).
"""
import os

from django.core.wsgi import get_wsgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "webfrontend.settings")
application = get_wsgi_application()

from harness.store.schema import ensure_schema  # noqa: E402  (needs the settings configured above)

ensure_schema()
