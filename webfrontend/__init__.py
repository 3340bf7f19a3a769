"""The dashboard (thesis 4.6): a Django project over the harness store, read-only except for overrides."""
