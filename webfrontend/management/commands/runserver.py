"""``runserver`` that first brings the store's schema up to date (harness.store.schema), so that
``python manage.py runserver`` opens a store the CLI created - or an older one - without a separate
``migrate``; static files stay with whitenoise (its runserver is the base class)."""
from django.core.management.base import CommandError
from whitenoise.runserver_nostatic.management.commands.runserver import (
    Command as WhitenoiseRunserver,
)

from harness.store.schema import SchemaBehind, ensure_schema


class Command(WhitenoiseRunserver):
    def check_migrations(self):
        # runs before the server starts (and Django's "unapplied migrations" warning is then moot)
        try:
            applied = ensure_schema()
        except SchemaBehind as exc:
            raise CommandError(str(exc)) from None
        if applied:
            self.stdout.write(f"store: applied {len(applied)} migration(s) ({applied[0]} ... {applied[-1]})")
        super().check_migrations()
