"""Engine adapters: one per DEM code family. Each knows its code's command line and output files.

An adapter is looked up by the name given in a target definition's ``"engine"`` field.
"""
from harness.adapters.base import EngineAdapter, LogScan, UserError  # noqa: F401

_ADAPTERS: dict[str, type] = {}


def register(cls):
    """Class decorator: make an adapter available under ``cls.name``."""
    _ADAPTERS[cls.name] = cls
    return cls


def get_adapter(name: str) -> EngineAdapter:
    # Import the built-in adapters lazily so that registration happens on first use.
    import importlib

    for module in ("dem", "liggghts"):
        try:
            importlib.import_module(f"harness.adapters.{module}")
        except ModuleNotFoundError as exc:
            # an adapter module not written (yet) is skipped; an import error inside one is not hidden
            if exc.name != f"harness.adapters.{module}":
                raise

    try:
        return _ADAPTERS[name]()
    except KeyError:
        known = ", ".join(sorted(_ADAPTERS))
        raise UserError(f"unknown engine adapter {name!r} (known: {known})") from None
