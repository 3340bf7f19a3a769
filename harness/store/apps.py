from django.apps import AppConfig


class HarnessConfig(AppConfig):
    name = "harness"
    verbose_name = "DEM test harness store"
    default_auto_field = "django.db.models.BigAutoField"
