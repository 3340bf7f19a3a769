"""Engine adapters: one per DEM code family. Each knows its code's command line and output files.

An adapter is looked up by the name given in a target definition's ``"engine"`` field:

- a built-in adapter: ``dem`` (the bundled engine), ``liggghts``, ``lammps``, ``yade``;
- ``generic:FILE``: the generic adapter configured by the JSON file FILE (absolute, or relative to the project
  folder), for a code without an adapter of its own (``harness/adapters/generic.py``);
- an adapter another installed package declares in the entry-point group ``dem_harness.adapters``
  (``[project.entry-points."dem_harness.adapters"] mycode = "mypackage.adapter:MyCodeAdapter"``; the value is
  an ``EngineAdapter`` subclass, the entry point's name is the engine name).
"""
import importlib
from importlib.metadata import entry_points

from harness.adapters.base import EngineAdapter, LogScan, UserError  # noqa: F401

#: entry-point group where other packages declare adapters (name -> EngineAdapter subclass)
ENTRY_POINT_GROUP = "dem_harness.adapters"
BUILTIN_MODULES = ("dem", "liggghts", "lammps", "yade", "generic")
GENERIC_PREFIX = "generic:"

_ADAPTERS: dict[str, type] = {}


def register(cls):
    """Class decorator: make an adapter available under ``cls.name``."""
    _ADAPTERS[cls.name] = cls
    return cls


def _load_builtins() -> None:
    # Import the built-in adapters lazily so that registration happens on first use.
    for module in BUILTIN_MODULES:
        try:
            importlib.import_module(f"harness.adapters.{module}")
        except ModuleNotFoundError as exc:
            # an adapter module not written (yet) is skipped; an import error inside one is not hidden
            if exc.name != f"harness.adapters.{module}":
                raise


def _entry_point(name: str):
    """The adapter class another package declares under ``name`` in ``ENTRY_POINT_GROUP``, or None."""

    for point in entry_points(group=ENTRY_POINT_GROUP):
        if point.name != name:
            continue
        try:
            cls = point.load()
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is the user's to fix: one line
            raise UserError(f"engine adapter {name!r}: entry point {point.value!r} of group "
                            f"{ENTRY_POINT_GROUP} cannot be loaded ({type(exc).__name__}: {exc})") from None
        if not (isinstance(cls, type) and issubclass(cls, EngineAdapter)):
            raise UserError(f"engine adapter {name!r}: entry point {point.value!r} of group {ENTRY_POINT_GROUP} "
                            "is not an EngineAdapter subclass")
        return cls
    return None


def known_adapters() -> list[str]:
    """Names of the built-in adapters and those declared through the entry-point group."""

    _load_builtins()
    names = set(_ADAPTERS) | {p.name for p in entry_points(group=ENTRY_POINT_GROUP)}
    return sorted(names - {"generic"}) + [f"{GENERIC_PREFIX}FILE"]


def get_adapter(name: str) -> EngineAdapter:
    """The adapter for a target's ``engine`` field (see the module docstring); UserError when unknown."""
    _load_builtins()
    if name.startswith(GENERIC_PREFIX):
        # the adapter modules import this package (register): imported after it, as the built-ins are
        from harness.adapters.generic import GenericAdapter

        return GenericAdapter.from_file(name[len(GENERIC_PREFIX):])
    if name in _ADAPTERS and name != "generic":
        return _ADAPTERS[name]()
    cls = _entry_point(name)
    if cls is not None:
        return cls()
    hint = " (the generic adapter is named generic:FILE, FILE its JSON configuration)" if name == "generic" else ""
    raise UserError(f"unknown engine adapter {name!r} (known: {', '.join(known_adapters())}){hint}")


def adapter_of_run(folder) -> EngineAdapter:
    """The built-in adapter whose log file a run folder holds (``log.dem``, ``log.liggghts``, ``log.lammps``,
    ``log.yade``): how a post script that serves several codes reads the run of the one that wrote it.
    UserError when the folder holds none of them."""
    from pathlib import Path

    _load_builtins()
    folder = Path(folder)
    for name, cls in _ADAPTERS.items():
        if name == "generic":
            continue
        adapter = cls()
        if (folder / adapter.log_file()).is_file():
            return adapter
    logs = ", ".join(cls().log_file() for name, cls in _ADAPTERS.items() if name != "generic")
    raise UserError(f"{folder}: no engine log ({logs}): not a run folder of a built-in engine")
