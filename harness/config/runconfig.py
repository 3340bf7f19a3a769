"""The run.config of a test case: ``{"runs": [...]}``, one object per run configuration.

The class docstrings and field descriptions are the text of docs/run-config.md (``harness.config.export``).
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field

from harness.config.base import FileModel

RUN_TYPES = ("serial", "mpi", "mpi/custom")
#: how a column becomes one number (``harness.acceptance.reduce_values``)
REDUCTIONS = ("end", "start", "min", "max", "mean")
SCALING_KINDS = ("strong", "weak")
CALL_GRAPHS = ("dwarf", "fp")
DEFAULT_TIMEOUT = 600.0

Number = Union[int, float]
Scalar = Union[str, int, float]
#: ``SERIES.COLUMN`` or a sum of such terms
Quantity = Annotated[str, Field(pattern=r"^\s*[^\s.+]+\.[^+]+(\+\s*[^\s.+]+\.[^+]+)*$")]


class Series(FileModel):
    """A CSV or whitespace table written by the run. Its columns are quantities ``NAME.COLUMN`` for
    expectations and plots; a series is scored against the reference run's through a plot of it."""

    name: str
    """the series' name: the ``SERIES`` of ``SERIES.COLUMN``"""
    file: str
    """the table's file, relative to the run folder (``post/restitution.csv``)"""
    columns: list[str] = []
    """chooses columns or, for a table without a header, names them"""


class Plot(FileModel):
    """Drawn on the dashboard and scored against the reference run's (each y column against x)."""

    model_config = {"extra": "allow"}
    name: str
    """the plot's name"""
    xdata: str
    """``SERIES.COLUMN`` of a declared series: the abscissa"""
    ydata: Union[str, list[str]]
    """``SERIES.COLUMN`` (one or a list) of declared series"""


class TextFile(FileModel):
    """A text file compared word by word with the reference run's (glossary: words)."""

    file: str
    """the file, relative to the run folder"""
    rtol: Number = 0.1
    """numbers match within max(rtol abs(ref), atol)"""
    atol: Number = 1e-12
    """numbers match within max(rtol abs(ref), atol)"""


class Data(FileModel):
    """What to read besides thermo::

        "data": {
          "series": [{"name": "restitution", "file": "post/restitution.csv", "columns": ["t", "e"]}],
          "plots": [{"name": "e_over_time", "xdata": "restitution.t", "ydata": ["restitution.e"],
                     "title": "Restitution", "xlabel": "time_[s]", "ylabel": "e_[1]", "legend": ["e"]}],
          "textfiles": ["post/summary.txt", {"file": "post/table.txt", "rtol": 0.01, "atol": 1e-12}]
        }

    A text file holding a numeric table with a header is also available to expectations under the file's stem
    (``restitution.e`` for ``restitution.txt``)."""

    series: list[Series] = []
    """tables the run writes (``name``, ``file`` required)"""
    plots: list[Plot] = []
    """plots of declared series (``xdata`` and ``ydata`` are ``SERIES.COLUMN``; title, labels, legend free)"""
    textfiles: list[Union[str, TextFile]] = []
    """files compared word by word: words must be equal, numbers within ``max(rtol abs(ref), atol)``"""


class Expectation(FileModel):
    """A statement about one quantity of this run alone (no reference needed)::

        "expectations": [
          {"quantity": "restitution.e", "value": 0.9, "rel_tol": 0.01},
          {"quantity": "thermo.ke", "at": "max", "upper": 1e-3, "name": "no energy gained"},
          {"quantity": "thermo.z[1]", "at": "end", "lower": 0.0}
        ]

    An expectation not met fails the run (reason ``expectation``) with the value found and the bounds, e.g.
    ``expectation thermo.vz[1] (end) = 0.501701 outside 0.9 +/- 1 % [0.891, 0.909]``."""

    quantity: Quantity
    """``SERIES.COLUMN`` (``thermo.ke``, ``thermo.vz[1]``, ``restitution.e``) or a sum of such terms
    (``thermo.ke + thermo.rke``)"""
    at: Literal[REDUCTIONS] = "end"
    """how the column becomes one number"""
    value: Number | None = None
    """the expected number, with ``rel_tol`` and/or ``abs_tol`` (the larger of the two applies)"""
    rel_tol: Annotated[Number, Field(ge=0)] | None = None
    """a fraction of abs(value)"""
    abs_tol: Annotated[Number, Field(ge=0)] | None = None
    """same unit as the quantity"""
    lower: Number | None = None
    """a bound instead of ``value``"""
    upper: Number | None = None
    """a bound instead of ``value``"""
    name: str | None = None
    """how the result is named in reports (default: ``QUANTITY (AT)``)"""


class ParticleCount(FileModel):
    """No particle lost, or no more than ``max_loss`` (an outlet)."""

    column: Quantity = "thermo.atoms"
    """the particle count"""
    max_loss: Annotated[Number, Field(ge=0)] = 0
    """particles that may leave"""


class Bounds(FileModel):
    quantity: Quantity
    """``SERIES.COLUMN`` or a sum of terms"""
    rel_tol: Annotated[Number, Field(ge=0)] | None = None
    """a fraction of the quantity's scale"""
    abs_tol: Annotated[Number, Field(ge=0)] | None = None
    """same unit as the quantity"""
    upper: Number | None = None
    """the largest value allowed"""
    after: Number | None = None
    """skips the start (same unit as the series' first column, e.g. step)"""


class Blowup(FileModel):
    max_overlap: Annotated[Number, Field(gt=0)]
    """largest overlap / radius before the run counts as blown up (default 0.5)"""


class Stability(FileModel):
    """Numerical checks of hard cases::

        "stability": {
          "finite": true,
          "particle_count": {"column": "thermo.atoms", "max_loss": 0},
          "energy_never_grows": {"quantity": "thermo.ke + thermo.rke", "rel_tol": 0.01, "after": 1000},
          "energy_drift": {"quantity": "thermo.energy", "rel_tol": 1e-6},
          "max_overlap": {"quantity": "thermo.max_overlap", "upper": 0.1}
        }

    Every run is checked by default for finite values in every series, for no particle lost and for no blow-up
    (largest overlap at most half a radius); a run that stops with every particle gone never succeeds by
    default. ``"particle_count": false``, ``"finite": false`` or ``"blowup": false`` drops one default check,
    ``"stability": false`` drops them all."""

    finite: bool = True
    """no NaN or infinity in any series"""
    particle_count: Union[Literal[False], ParticleCount] = ParticleCount()
    """particles that may leave (``max_loss``, an outlet)"""
    energy_never_grows: Bounds | None = None
    """for closed dissipative systems: no value exceeds the running minimum before it by more than
    ``rel_tol`` x the largest abs value (+ ``abs_tol``)"""
    energy_drift: Bounds | None = None
    """for conservative systems: every value within ``rel_tol`` (or ``abs_tol``) of the first"""
    max_overlap: Bounds | None = None
    """``upper``: the largest overlap allowed, a fraction of the radius"""
    blowup: Union[Literal[False], Blowup] = Blowup(max_overlap=0.5)
    """a declared hard case relaxes the limit: ``{"max_overlap": 0.8}``"""


class ErrorSpec(FileModel):
    quantity: Annotated[str, Field(pattern=r"\.")]
    """``SERIES.COLUMN``, e.g. ``thermo.ke``"""
    at: Literal[REDUCTIONS] = "end"
    """how the column becomes one number"""
    exact: Number | None = None
    """the exact value; without it, the finest run's value"""


class Sweep(FileModel):
    """One run per value of a variable, to see what accuracy costs in time::

        "sweep": {"variable": "DT", "values": [4e-4, 2e-4, 1e-4],
                  "with": {"STEPS": [250, 500, 1000]},
                  "error": {"quantity": "thermo.z[1]", "at": "end", "exact": 1.0}}

    Expanded into one ordinary run per value, named ``NAME@DT=0.0004``; the error is abs(q - exact), or abs(q -
    q of the finest run) without ``exact``. ``harness sweep`` and the dashboard's "accuracy vs time" show error
    against run time and the observed order of convergence."""

    variable: Annotated[str, Field(min_length=1)]
    """the swept variable (passed as ``-var NAME VALUE``)"""
    values: Annotated[list[Annotated[Number, Field(gt=0)]], Field(min_length=2)]
    """at least two distinct values > 0 (the plot is log-log)"""
    with_: dict[str, list[Scalar]] = Field({}, alias="with")
    """further variables that change together with the swept one, one value per sweep value"""
    error: ErrorSpec
    """the quantity whose error is measured"""
    finest: Literal["min", "max"] = "min"
    """``max`` when a larger value is finer (a particle count)"""


class Scaling(FileModel):
    """How the code scales with cores::

        "scaling": {"cores": [1, 2, 4]}
        "scaling": {"cores": [1, 2, 4], "kind": "weak", "with": {"N": [4000, 8000, 16000]}}

    Expanded into one run per core count, named ``NAME@cores=P``: MPI ranks for a code that parallelises with
    MPI, threads for one that uses threads (the bundled engine, YADE). Not with a sweep, nor with type
    ``mpi/custom``. ``harness scaling`` shows speedup, efficiency and the Karp-Flatt serial fraction."""

    cores: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=2)]
    """at least two distinct core counts >= 1"""
    kind: Literal[SCALING_KINDS] = "strong"
    """``weak``: the size grows with the cores (``with`` required)"""
    with_: dict[str, list[Scalar]] = Field({}, alias="with")
    """further variables, one value per core count (``-var N 8000``)"""


class Profile(FileModel):
    call_graph: Literal[CALL_GRAPHS] = "dwarf"
    """how perf records the call stacks"""
    frequency: Annotated[int, Field(ge=1, le=20000)] = 249
    """samples per second"""


class QuantityConsistency(FileModel):
    epsilon: Annotated[Number, Field(ge=0)] | None = None
    """replaces eq. 4.2; same unit as the quantity"""
    floor: Annotated[Number, Field(ge=0)] | None = None
    """the smallest eps"""
    rtol: Annotated[Number, Field(ge=0)] | None = None
    """text files: relative tolerance of numbers"""
    atol: Annotated[Number, Field(ge=0)] | None = None
    """text files: absolute tolerance of numbers"""
    ignore: bool = False
    """leave the quantity out"""


class Vtk(FileModel):
    density: Annotated[Number, Field(gt=0)]
    """kg/m^3: the density for the kinetic energy of VTK dumps"""


class RunEntry(FileModel):
    """A run configuration. A problem in one makes it fail (reason ``config``) while the others run."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.,:=@+\-]*$", max_length=200)]
    """unique in the file; a safe name (letters, digits, ``_ . , : = @ + -``): it names the run's folder"""
    script: Union[str, dict[str, str]]
    """the input script, a file of the test case folder; or one per engine adapter, ``{"dem": "scene.json",
    "liggghts": "in.scene"}`` (a target whose adapter has no entry does not run it)"""
    description: str | None = None
    """free text"""
    type: Literal[RUN_TYPES] = "serial"
    """``serial``, ``mpi`` with ``nprocs``, or ``mpi/custom`` with ``mpi_options``"""
    nprocs: Annotated[int, Field(ge=1)] | None = None
    """MPI ranks of a run of type ``mpi``"""
    mpi_options: Union[str, list[str]] | None = None
    """added to the launcher of a run of type ``mpi/custom`` (a string split like a shell, or a list)"""
    variables: dict[str, Scalar] = {}
    """``{"NAME": value}``: passed to the engine as ``-var NAME VALUE`` (``${NAME}`` in a bundled-engine scene)"""
    depends_on: str | None = None
    """a run of the same folder that runs first; its ``post/`` folder is copied into this run's folder (a
    restart file, a settled bed)"""
    post_scripts: list[str] = []
    """executables of the test case folder (with a shebang), run in order in the run folder after the engine"""
    data: Data | None = None
    """what to read besides thermo: ``series``, ``plots``, ``textfiles``"""
    timeout: Annotated[Number, Field(gt=0)] = DEFAULT_TIMEOUT
    """seconds before the run is stopped and recorded as failed (reason ``timeout``)"""
    thermo_columns: dict[str, str] = {}
    """``{"ke": "KinEng"}``: which of the engine's thermo columns are the harness' step, atoms, ke, rke"""
    consistency: dict[str, QuantityConsistency] = {}
    """per quantity (``ke``, ``SERIES:QUANTITY``, a series or text file name, or ``*`` for every quantity), how
    it is scored against the reference run. By default every quantity of thermo, series and plots except the
    abscissa is scored with ``eps = 0.1 (max - min) / 2`` of the reference, at least a floor of 1e-6 x the
    largest abs reference value; the thermo columns ``step`` and ``time`` are axes, scored only when named"""
    vtk: Vtk | None = None
    """``{"density": 2500}``"""
    expectations: list[Expectation] = []
    """statements about quantities that must hold"""
    stability: Union[Literal[False], Stability] = Stability()
    """numerical checks of hard cases (``false``: none)"""
    sweep: Sweep | None = None
    """one run per value of a variable, to see what accuracy costs in time"""
    scaling: Scaling | None = None
    """one run per core count: a strong or weak scaling study"""
    profile: Union[bool, Profile] = False
    """profile a native code with perf (``true``, or ``{"call_graph": "fp", "frequency": 999}``)"""
    sweep_point: dict | None = None
    """set by discovery on the runs a sweep expands into; not written by hand"""
    scaling_point: dict | None = None
    """set by discovery on the runs a scaling study expands into; not written by hand"""


class RunConfig(FileModel):
    """A test case is a folder with a ``run.config``: a JSON object with ``runs``, a list of run
    configurations::

        {
          "description": "What the test case shows, and where the numbers come from.",
          "runs": [
            {"name": "bounce", "script": "scene.json", "variables": {"E": 0.9, "DT": 1e-5, "STEPS": 400},
             "expectations": [{"quantity": "thermo.vz[1]", "at": "end", "value": 0.9, "rel_tol": 0.01}]}
          ]
        }

    Every field is checked by ``harness validate`` (nothing is built or run) and by ``harness run``; a problem
    names the file and the JSON path, e.g. ``cases/drop/run.config: $.runs[0].expectations[0]: unknown
    field(s) rel_tolerance``, and a run with a problem is recorded as failed (reason ``config``) while the
    others run. ``harness new testcase NAME`` writes a working example.

    A folder without ``run.config`` may still be a test case when the engine adapter supplies one (LIGGGHTS:
    one serial run per ``in.*`` script). Folders named ``post``, ``restart``, ``meshes``, ``scripts``,
    ``__pycache__`` are parts of a test case, never test cases themselves."""

    runs: list[RunEntry]
    """the run configurations"""
    description: str | None = None
    """what the test case shows, and where the numbers come from"""
