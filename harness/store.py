"""Open the store from outside Django (the CLI, scripts): configure settings once and migrate."""
import os

_ready = False


def setup_store(migrate: bool = True) -> None:
    """Configure Django with the store settings (unless already configured) and bring the schema up to date."""
    global _ready
    if _ready:
        return
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "harness.settings")
    import django
    from django.core.management import call_command

    django.setup()
    if migrate:
        call_command("migrate", verbosity=0, interactive=False)
    _ready = True
