"""Fixtures for the harness tests: a throw-away store, temporary git repositories, a fake engine.

``HARNESS_HOME`` points at a temporary folder before Django is configured, so neither these tests nor the
CLI they start ever touch a user's store.
"""
from store_fixtures import store_fixtures

django_store, store = store_fixtures("harness-tests-")
