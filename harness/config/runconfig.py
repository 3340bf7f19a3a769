"""The run.config of a test case: ``{"runs": [...]}``, one object per run configuration.

The class docstrings and field descriptions are the text of docs/run-config.md (``harness.config.export``).
"""
from __future__ import annotations

from typing import Annotated, ClassVar, Literal, Union

from pydantic import Field

from harness.config.base import FileModel
from harness.config.check import Says

RUN_TYPES = ("serial", "mpi", "mpi/custom")
#: how a column becomes one number (``harness.config.acceptance.reduce_values``)
REDUCTIONS = ("end", "start", "min", "max", "mean")
SCALING_KINDS = ("strong", "weak")
#: how perf finds the callers (harness.execution.profiles): "dwarf" unwinds from debug information and works for binaries
#: built without frame pointers (Debian's liggghts and lmp); "fp" (perf record -g's default) is cheaper but needs
#: a code compiled with -fno-omit-frame-pointer, else most stacks end after one frame
CALL_GRAPHS = ("dwarf", "fp")
#: samples per second per thread: enough for runs of seconds; a DWARF sample copies 8 kB of stack, so this
#: bounds perf.data to about 2 MB per second and rank
PERF_FREQUENCY = 249
#: a safe single path segment (``harness.execution.workspace.segment_problem`` says why a name is not one)
SAFE_NAME = r"^[A-Za-z0-9_][A-Za-z0-9_.,:=@+\-]*$"
DEFAULT_TIMEOUT = 600.0

Number = float  # strict: an integer is a number, true is not
Scalar = Union[str, int, float]
#: ``SERIES.COLUMN`` or a sum of such terms
Quantity = Annotated[str, Field(pattern=r"^\s*[^\s.+]+\.[^+]+(\+\s*[^\s.+]+\.[^+]+)*$"),
                     Says(what="a string SERIES.COLUMN, e.g. 'thermo.ke'",
                          missing="must be a string SERIES.COLUMN, e.g. 'thermo.ke'",
                          bound="{value!r} is not of the form SERIES.COLUMN (or a sum of such terms)")]
FiniteNumber = Annotated[Number, Says(what="a finite number")]
Tolerance = Annotated[Number, Field(ge=0), Says(what="a finite number", bound="must be >= 0, got {value!r}")]
NonNegative = Annotated[Number, Field(ge=0), Says(what="a number", bound="must not be negative")]
Variables = Annotated[dict[str, list[Scalar]], Says(
    what="an object mapping variable names to lists of values", item="a list with one value per point")]


class Series(FileModel):
    """A CSV or whitespace table written by the run. Its columns are quantities ``NAME.COLUMN`` for
    expectations and plots; a series is scored against the reference run's through a plot of it."""

    model_config = {"extra": "allow"}
    name: str
    """the series' name: the ``SERIES`` of ``SERIES.COLUMN``"""
    file: str
    """the table's file, relative to the run folder (``post/restitution.csv``)"""
    columns: Annotated[list[str], Says(what="a list of column names", item="a string")] = []
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

    model_config = {"extra": "allow"}
    file: Annotated[str, Says(message="required (a string)")]
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

    series: Annotated[list[Series], Says(what="a list", item="an object")] = []
    """tables the run writes (``name``, ``file`` required)"""
    plots: Annotated[list[Plot], Says(what="a list", item="an object")] = []
    """plots of declared series (``xdata`` and ``ydata`` are ``SERIES.COLUMN``; title, labels, legend free)"""
    textfiles: Annotated[list[Union[str, TextFile]],
                         Says(what="a list", item="a file name or an object with 'file'")] = []
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

    says: ClassVar[Says] = Says(unknown="unknown field(s) {fields}", unknown_here=True)
    quantity: Quantity
    """``SERIES.COLUMN`` (``thermo.ke``, ``thermo.vz[1]``, ``restitution.e``) or a sum of such terms
    (``thermo.ke + thermo.rke``)"""
    at: Annotated[Literal[REDUCTIONS], Says(bound="must be one of end, start, min, max, mean, got {value!r}")] \
        = "end"
    """how the column becomes one number"""
    value: FiniteNumber | None = None
    """the expected number, with ``rel_tol`` and/or ``abs_tol`` (the larger of the two applies)"""
    rel_tol: Tolerance | None = None
    """a fraction of abs(value)"""
    abs_tol: Tolerance | None = None
    """same unit as the quantity"""
    lower: FiniteNumber | None = None
    """a bound instead of ``value``"""
    upper: FiniteNumber | None = None
    """a bound instead of ``value``"""
    name: str | None = None
    """how the result is named in reports (default: ``QUANTITY (AT)``)"""
    engines: Annotated[list[str], Says(what="a list of engine adapter names", item="a string")] | None = None
    """the engine adapters of the targets it holds for (``["dem", "liggghts"]``); default: every one. For a
    statement about a model that some codes compute differently by design (docs/shapes.md)"""


class ParticleCount(FileModel):
    """No particle lost, or no more than ``max_loss`` (an outlet)."""

    column: Quantity = "thermo.atoms"
    """the particle count"""
    max_loss: Annotated[Number, Field(ge=0), Says(message="must be a number >= 0")] = 0
    """particles that may leave"""


class Bounds(FileModel):
    quantity: Quantity
    """``SERIES.COLUMN`` or a sum of terms"""
    rel_tol: Tolerance | None = None
    """a fraction of the quantity's scale"""
    abs_tol: Tolerance | None = None
    """same unit as the quantity"""
    upper: FiniteNumber | None = None
    """the largest value allowed"""
    after: Annotated[Number, Says(message="must be a number")] | None = None
    """skips the start (same unit as the series' first column, e.g. step)"""


BLOWUP = ('must be false or {{"max_overlap": X}} with X > 0 (largest overlap / radius before the run counts '
          'as blown up)')


class Blowup(FileModel):
    says: ClassVar[Says] = Says(unknown=BLOWUP.replace("{{", "{").replace("}}", "}"))

    max_overlap: Annotated[Number, Field(gt=0), Says(message=BLOWUP)]
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

    says: ClassVar[Says] = Says(unknown="unknown check (known: {known})")
    finite: Annotated[bool, Says(message="must be true or false")] = True
    """no NaN or infinity in any series"""
    particle_count: Annotated[Union[Literal[False], ParticleCount], Says(what="an object")] = ParticleCount()
    """particles that may leave (``max_loss``, an outlet)"""
    energy_never_grows: Bounds | None = None
    """for closed dissipative systems: no value exceeds the running minimum before it by more than
    ``rel_tol`` x the largest abs value (+ ``abs_tol``)"""
    energy_drift: Bounds | None = None
    """for conservative systems: every value within ``rel_tol`` (or ``abs_tol``) of the first"""
    max_overlap: Bounds | None = None
    """``upper``: the largest overlap allowed, a fraction of the radius"""
    blowup: Annotated[Union[Literal[False], Blowup], Says(message=BLOWUP)] = Blowup(max_overlap=0.5)
    """a declared hard case relaxes the limit: ``{"max_overlap": 0.8}``"""


class ErrorSpec(FileModel):
    quantity: Annotated[str, Field(pattern=r"\."), Says(message="must be SERIES.COLUMN, e.g. 'thermo.ke'")]
    """``SERIES.COLUMN``, e.g. ``thermo.ke``"""
    at: Annotated[Literal[REDUCTIONS], Says(message="must be one of end, start, min, max, mean")] = "end"
    """how the column becomes one number"""
    exact: Annotated[Number, Says(message="must be a number")] | None = None
    """the exact value; without it, the finest run's value"""


class Sweep(FileModel):
    """One run per value of a variable, to see what accuracy costs in time::

        "sweep": {"variable": "DT", "values": [4e-4, 2e-4, 1e-4],
                  "with": {"STEPS": [250, 500, 1000]},
                  "error": {"quantity": "thermo.z[1]", "at": "end", "exact": 1.0}}

    Expanded into one ordinary run per value, named ``NAME@DT=0.0004``; the error is abs(q - exact), or abs(q -
    q of the finest run) without ``exact``. ``harness sweep`` and the dashboard's "accuracy vs time" show error
    against run time and the observed order of convergence."""

    variable: Annotated[str, Field(min_length=1), Says(message="must be a variable name (passed as -var NAME VALUE)")]
    """the swept variable (passed as ``-var NAME VALUE``)"""
    values: Annotated[list[Annotated[Number, Field(gt=0)]], Field(min_length=2), Says(
        what="a list of at least two values", bound="must be a list of at least two values",
        item="a number > 0 (the plot is log-log)", item_bound="must be a number > 0 (the plot is log-log)")]
    """at least two distinct values > 0 (the plot is log-log)"""
    with_: Variables = Field({}, alias="with")
    """further variables that change together with the swept one, one value per sweep value"""
    error: Annotated[ErrorSpec, Says(what="an object with quantity (SERIES.COLUMN) and optionally at, exact",
                                     missing="must be an object with quantity (SERIES.COLUMN) and optionally at, "
                                     "exact")]
    """the quantity whose error is measured"""
    finest: Annotated[Literal["min", "max"], Says(message="must be 'min' or 'max'")] = "min"
    """``max`` when a larger value is finer (a particle count)"""


class Scaling(FileModel):
    """How the code scales with cores::

        "scaling": {"cores": [1, 2, 4]}
        "scaling": {"cores": [1, 2, 4], "kind": "weak", "with": {"N": [4000, 8000, 16000]}}

    Expanded into one run per core count, named ``NAME@cores=P``: MPI ranks for a code that parallelises with
    MPI, threads for one that uses threads (the bundled engine, YADE). Not with a sweep, nor with type
    ``mpi/custom``. ``harness scaling`` shows speedup, efficiency and the Karp-Flatt serial fraction."""

    cores: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=2), Says(
        message="must be a list of at least two core counts, e.g. [1, 2]",
        item_bound="every core count must be an integer >= 1")]
    """at least two distinct core counts >= 1"""
    kind: Annotated[Literal[SCALING_KINDS], Says(message="must be one of strong, weak")] = "strong"
    """``weak``: the size grows with the cores (``with`` required)"""
    with_: Variables = Field({}, alias="with")
    """further variables, one value per core count (``-var N 8000``)"""


class Profile(FileModel):
    call_graph: Annotated[Literal[CALL_GRAPHS], Says(message="must be one of dwarf, fp")] = "dwarf"
    """how perf records the call stacks"""
    frequency: Annotated[int, Field(ge=1, le=20000), Says(
        message="must be an integer number of samples per second, 1 to 20000")] = PERF_FREQUENCY
    """samples per second"""


class QuantityConsistency(FileModel):
    """How one quantity is scored against the reference run (glossary: C, eps, band)::

        "consistency": {
          "ke": {"epsilon": 1e-6},
          "thermo:atoms": {"floor": 0.5},
          "time": {},
          "post/summary.txt": {"rtol": 0.01},
          "cpu_load": {"ignore": true},
          "*": {"floor": 1e-9}
        }

    Keys are a quantity (``ke``), ``SERIES:QUANTITY``, a series or text file name, or ``*`` for every
    quantity; ``harness.analysis.consistency`` computes the score."""

    epsilon: NonNegative | None = None
    """replaces eq. 4.2; same unit as the quantity"""
    floor: NonNegative | None = None
    """the smallest eps"""
    rtol: NonNegative | None = None
    """text files: relative tolerance of numbers"""
    atol: NonNegative | None = None
    """text files: absolute tolerance of numbers"""
    ignore: bool = False
    """leave the quantity out"""


class Vtk(FileModel):
    density: Annotated[Number, Field(gt=0), Says(what="a number (kg/m^3)", bound="must be positive")] | None = None
    """kg/m^3: the density for the kinetic energy of VTK dumps"""


class RunConfigEntry(FileModel):
    """A run configuration. A problem in one makes it fail (reason ``config``) while the others run."""

    name: Annotated[str, Field(json_schema_extra={"pattern": SAFE_NAME, "maxLength": 200})]
    """unique in the file; a safe name (letters, digits, ``_ . , : = @ + -``): it names the run's folder"""
    script: Annotated[Union[str, dict[str, str]], Says(what="a file name or an object per engine adapter",
                                                       item="a file name")]
    """the input script, a file of the test case folder; or one per engine adapter, ``{"dem": "scene.json",
    "liggghts": "in.scene"}`` (a target whose adapter has no entry does not run it)"""
    description: str | None = None
    """free text"""
    type: Annotated[Literal[RUN_TYPES], Says(bound="unknown run type {value!r} (known: {known})")] = "serial"
    """``serial``, ``mpi`` with ``nprocs``, or ``mpi/custom`` with ``mpi_options``"""
    nprocs: Annotated[int, Field(ge=1), Says(bound="must be at least 1")] | None = None
    """MPI ranks of a run of type ``mpi``"""
    mpi_options: Annotated[Union[str, list[str]], Says(what="a string or a list of strings", item="a string")] \
        | None = None
    """added to the launcher of a run of type ``mpi/custom`` (a string split like a shell, or a list)"""
    variables: Annotated[dict[str, Scalar], Says(what="an object", item="a string or number")] = {}
    """``{"NAME": value}``: passed to the engine as ``-var NAME VALUE`` (``${NAME}`` in a bundled-engine scene)"""
    depends_on: Annotated[str, Says(what="a run name")] | None = None
    """a run of the same folder that runs first; its ``post/`` folder is copied into this run's folder (a
    restart file, a settled bed)"""
    post_scripts: Annotated[list[str], Says(what="a list of file names", item="a file name")] = []
    """executables of the test case folder (with a shebang), run in order in the run folder after the engine"""
    data: Data | None = None
    """what to read besides thermo: ``series``, ``plots``, ``textfiles``"""
    timeout: Annotated[Number, Field(gt=0), Says(what="a number of seconds", bound="must be positive")] \
        = DEFAULT_TIMEOUT
    """seconds before the run is stopped and recorded as failed (reason ``timeout``)"""
    thermo_columns: Annotated[dict[str, str], Says(what="an object", item="a column name (string)")] = {}
    """``{"ke": "KinEng"}``: which of the engine's thermo columns are the harness' step, atoms, ke, rke"""
    consistency: Annotated[dict[str, QuantityConsistency],
                           Says(what="an object", item="an object with epsilon and/or floor")] = {}
    """per quantity (``ke``, ``SERIES:QUANTITY``, a series or text file name, or ``*`` for every quantity), how
    it is scored against the reference run. By default every quantity of thermo, series and plots except the
    abscissa is scored with ``eps = 0.1 (max - min) / 2`` of the reference, at least a floor of 1e-6 x the
    largest abs reference value; the thermo columns ``step`` and ``time`` are axes, scored only when named"""
    vtk: Vtk | None = None
    """``{"density": 2500}``"""
    expectations: Annotated[list[Expectation], Says(what="a list of objects", item="an object")] = []
    """statements about quantities that must hold"""
    stability: Annotated[Union[Literal[False], Stability],
                         Says(what="an object (or false: no default checks)")] = Stability()
    """numerical checks of hard cases (``false``: none)"""
    sweep: Annotated[Sweep, Says(what="an object with variable, values and error")] | None = None
    """one run per value of a variable, to see what accuracy costs in time"""
    scaling: Annotated[Scaling, Says(
        what="an object with cores (a list of core counts) and optionally kind and with")] | None = None
    """one run per core count: a strong or weak scaling study"""
    profile: Annotated[Union[bool, Profile], Says(
        what="true, false or an object with call_graph (dwarf, fp) and frequency (Hz)")] = False
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

    runs: Annotated[list[RunConfigEntry], Says(what="a list of run configurations", item="a run configuration object")]
    """the run configurations"""
    description: str | None = None
    """what the test case shows, and where the numbers come from"""
