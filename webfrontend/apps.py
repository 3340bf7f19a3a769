from django.apps import AppConfig


class WebfrontendConfig(AppConfig):
    name = "webfrontend"
    verbose_name = "DEM harness dashboard"
