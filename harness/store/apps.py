from django.apps import AppConfig


class HarnessConfig(AppConfig):
    """The store as a Django app: the package ``harness.store`` under the app label ``harness`` it always had,
    so its tables (``harness_run``, ...) and its migration history (``django_migrations`` rows of app
    ``harness``) are those of every existing store."""

    name = "harness.store"
    label = "harness"
    verbose_name = "DEM test harness store"
    default_auto_field = "django.db.models.BigAutoField"
