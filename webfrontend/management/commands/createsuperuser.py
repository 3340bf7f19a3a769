"""``createsuperuser`` that first brings the store's schema up to date (harness.store.schema): on a fresh clone
it may be the first command that opens the store."""
from django.contrib.auth.management.commands.createsuperuser import (
    Command as CreateSuperuser,
)
from django.core.management.base import CommandError

from harness.store.schema import SchemaBehind, ensure_schema


class Command(CreateSuperuser):
    def check_migrations(self):
        # Django calls this before handle() (requires_migrations_checks) and would warn of unapplied ones
        try:
            ensure_schema()
        except SchemaBehind as exc:
            raise CommandError(str(exc)) from None
        super().check_migrations()
