from django.contrib import admin

from harness.store.models import Override


@admin.register(Override)
class OverrideAdmin(admin.ModelAdmin):
    list_display = ("run", "quantity", "user", "created")
    readonly_fields = ("created",)
