"""The generic adapter: a DEM code without an adapter of its own, described by a JSON file instead of Python.

A target names it as ``"engine": "generic:FILE"`` (FILE absolute, or relative to the project folder). The
file says how to start the code and where its results land::

    {
      "description": "our in-house code",
      "command": ["{executable}", "--input", "{script}", "{variables}", "--log", "{log}"],
      "variable": ["--set", "{name}={value}"],
      "log": "run.log",
      "scripts": ["*.ini"],
      "thermo": {"csv": "out/energy.csv", "delimiter": ",",
                 "columns": {"step": "iteration", "atoms": "n", "ke": "E_trans", "rke": "E_rot"}},
      "timing": {"total": "^Loop took (\\\\S+) s", "pair": "^contacts: (\\\\S+) s"},
      "errors": ["^ERROR", "^Fatal"],
      "warnings": ["^WARNING"],
      "vtk": ["post/*.vtp"]
    }

``command`` (required): the command line; ``{executable}`` becomes the target's executable (all its words),
``{script}`` the run's script, ``{log}`` the log file name, ``{variables}`` one copy of ``variable`` per
run.config variable (default ``["-var", "{name}", "{value}"]``); an mpi run puts the launcher in front.
``log``: the log file (default ``log.txt``). ``scripts``: glob patterns of the scripts a plain run.config
``script`` may name for this code (default: any). ``thermo`` (required): either ``csv`` (a file in the run
folder; ``delimiter`` ``,`` by default, ``whitespace`` for columns separated by blanks) or ``log_pattern`` (a
regular expression with named groups, one row per matching line of the log, or of ``file``), and
``columns``, the code's names for step, atoms, ke, rke (unmapped ones must be printed under those names).
``timing``: per harness timing key (total, pair, neigh, comm, modify, output, other) a regular expression
whose first group is seconds, summed over the log's matching lines. ``errors`` / ``warnings``: regular
expressions for log, stdout and stderr lines (defaults ``^ERROR`` / ``^WARNING``). ``vtk``: glob patterns of
the particle dumps (VTK files), in step order.

Every problem of the file is one line naming it and the JSON path (``harness.config.jsonfile``).
"""
from __future__ import annotations

import fnmatch
import re
from pathlib import Path

from harness.adapters.base import EngineAdapter, LogScan, UserError
from harness.config import check
from harness.config.adapter import TIMING_KEYS, AdapterFile
from harness.config.jsonfile import Problems, load_json
from harness.execution.postprocess import dump_step
from harness.execution.workspace import PROJECT_ROOT


def validate(data, path: Path) -> None:
    """Raise a UserError listing every problem of a generic adapter file (``$.json.path: what``): the
    schema's (``harness.config.adapter``) and the regular expressions that do not compile or lack a group."""
    problems = Problems(path)
    if not isinstance(data, dict):
        problems.add((), "a generic adapter file must be a JSON object")
        problems.raise_if_any()
    problems.extend(check.validate(AdapterFile, data)[1])
    command = data.get("command")
    if isinstance(command, list) and all(isinstance(w, str) for w in command) and "{script}" not in " ".join(command):
        problems.add(("command",), "must contain {script}")
    thermo = data.get("thermo")
    if isinstance(thermo, dict) and ("csv" in thermo) == ("log_pattern" in thermo):
        problems.add(("thermo",), "needs exactly one of csv and log_pattern")
    for where, pattern in _patterns(data):
        try:
            compiled = re.compile(pattern)
        except re.error as exc:
            problems.add(where, f"not a regular expression ({exc})")
            continue
        if where[0] == "timing" and compiled.groups < 1:
            problems.add(where, "needs a group holding the seconds")
        if where == ("thermo", "log_pattern") and "(?P<" not in pattern:
            problems.add(where, "needs named groups, e.g. (?P<step>\\d+)")
    problems.raise_if_any()


def _patterns(data: dict):
    """(JSON path, text) of every regular expression of the file that is a string."""
    for key in ("errors", "warnings"):
        for i, pattern in enumerate(data.get(key) if isinstance(data.get(key), list) else []):
            if isinstance(pattern, str):
                yield (key, i), pattern
    thermo = data.get("thermo") if isinstance(data.get("thermo"), dict) else {}
    if isinstance(thermo.get("log_pattern"), str):
        yield ("thermo", "log_pattern"), thermo["log_pattern"]
    timing = data.get("timing") if isinstance(data.get("timing"), dict) else {}
    for key, pattern in timing.items():
        if key in TIMING_KEYS and isinstance(pattern, str):
            yield ("timing", key), pattern


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return float("nan")


class GenericAdapter(EngineAdapter):
    """An adapter whose command line and output files come from a JSON description (module docstring)."""

    def __init__(self, config: dict, name: str = "generic", source: str = "generic adapter"):
        self.config = config
        self.name = name
        self.source = source
        thermo = config.get("thermo", {})
        self.default_thermo_columns = dict(thermo.get("columns", {}))

    @classmethod
    def from_file(cls, file: str) -> "GenericAdapter":
        """The adapter described by ``file`` (absolute, or relative to the project folder); its name is
        ``generic:FILE`` as written, so that a run record names the same adapter again."""

        if not file:
            raise UserError("engine 'generic:': name the adapter file, e.g. generic:targets/adapters/mycode.json")
        path = Path(file).expanduser()
        if not path.is_absolute():
            path = PROJECT_ROOT / path
        if not path.is_file():
            raise UserError(f"{path}: generic adapter file not found (engine 'generic:{file}')")
        data = load_json(path)
        validate(data, path)
        return cls(data, name=f"generic:{file}", source=str(path))

    # -- command line -----------------------------------------------------------------------------------
    def command(self, executable, script, variables, log, mpi=None):
        template = self.config["command"]
        per_variable = self.config.get("variable", ["-var", "{name}", "{value}"])
        command = list(mpi or [])
        for word in template:
            if word == "{executable}":
                command += list(executable)
            elif word == "{variables}":
                for name, value in (variables or {}).items():
                    command += [w.replace("{name}", str(name)).replace("{value}", str(value)) for w in per_variable]
            else:
                command.append(word.replace("{script}", script).replace("{log}", log))
        return command

    def log_file(self) -> str:
        return self.config.get("log", "log.txt")

    def accepts_script(self, script: str) -> bool:
        patterns = self.config.get("scripts")
        return True if not patterns else any(fnmatch.fnmatch(Path(script).name, p) for p in patterns)

    # -- results ----------------------------------------------------------------------------------------
    def _log_lines(self, folder: Path, name: str | None = None) -> list[str]:
        path = Path(folder) / (name or self.log_file())
        try:
            return path.read_text(errors="replace").splitlines()
        except FileNotFoundError:
            raise UserError(f"{path}: no log (did the run start?)") from None

    def read_thermo(self, folder, mapping=None):
        """The thermo table from the CSV file or the log lines the description names, mapped onto step,
        atoms, ke, rke (``thermo_columns`` of target/run.config first, then the description's ``columns``)."""
        # a heavy library, loaded when this runs, not at every `harness` start
        import pandas as pd

        folder = Path(folder)
        thermo = self.config["thermo"]
        if "csv" in thermo:
            path = folder / thermo["csv"]
            if not path.is_file():
                raise UserError(f"{path}: no thermo output (thermo.csv of {self.source})")
            delimiter = thermo.get("delimiter", ",")
            try:
                if delimiter == "whitespace":
                    table = pd.read_csv(path, sep=r"\s+", encoding_errors="replace")
                else:
                    table = pd.read_csv(path, sep=delimiter, skipinitialspace=True, encoding_errors="replace")
            except (pd.errors.EmptyDataError, pd.errors.ParserError) as exc:
                raise UserError(f"{path}: unreadable ({str(exc).splitlines()[0]})") from None
            table.columns = [str(c).strip() for c in table.columns]
            source = str(path)
        else:
            name = thermo.get("file") or self.log_file()
            pattern = re.compile(thermo["log_pattern"])
            rows = [{k: _number(v) for k, v in m.groupdict().items() if v is not None}
                    for line in self._log_lines(folder, name) if (m := pattern.search(line))]
            table = pd.DataFrame(rows)
            source = str(folder / name)
        if table.empty:
            raise UserError(f"{source}: no thermo rows")
        return self.map_thermo(table, mapping, source)

    def read_timing(self, folder):
        """Seconds per timing key: the first group of the key's pattern, summed over the log's lines."""
        timing = {key: 0.0 for key in TIMING_KEYS}
        patterns = {key: re.compile(p) for key, p in self.config.get("timing", {}).items()}
        if not patterns:
            return timing
        try:
            lines = self._log_lines(Path(folder))
        except UserError:
            return timing
        for line in lines:
            for key, pattern in patterns.items():
                m = pattern.search(line)
                if m:
                    value = _number(m.group(1))
                    if value == value:
                        timing[key] += value
        return timing

    def scan_log(self, folder) -> LogScan:
        """Lines of the log, stdout and stderr matching ``errors`` (each once) and the log's ``warnings``."""
        folder = Path(folder)
        errors = [re.compile(p) for p in self.config.get("errors", ["^ERROR"])]
        warnings = [re.compile(p) for p in self.config.get("warnings", ["^WARNING"])]
        scan = LogScan()
        log = folder / self.log_file()
        for source in [log] + sorted(p for p in folder.glob("std*") if p.is_file()):
            if not source.is_file():
                continue
            for line in source.read_text(errors="replace").splitlines():
                text = line.strip()
                if any(p.search(text) for p in errors):
                    if text not in scan.errors:
                        scan.errors.append(text)
                elif source == log and any(p.search(text) for p in warnings):
                    scan.warnings.append(text)
        return scan

    def vtk_files(self, folder):

        folder = Path(folder)
        found = []
        for order, pattern in enumerate(self.config.get("vtk", [])):
            for path in folder.glob(pattern):
                if path.is_file() and path not in [f for _, _, f in found]:
                    found.append((dump_step(path) or 0, order, path))
        return [path for _, _, path in sorted(found)]
