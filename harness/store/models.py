"""The store: machines, targets, builds, test cases, runs, post-processed series, consistency, overrides.

Run states follow the dissertation (ch. 4.3.4): not executed, executed, failed, post-processed,
version-consistency-checked, outdated; a failed run also carries a failure reason.
Artifacts stay on disk in the run folder; the store keeps what lists, plots and checks need.
"""
from django.conf import settings
from django.db import models

from harness.config.record import FAILURE_LABELS, STATE_LABELS
from harness.store.queries import BuildQuerySet, RunQuerySet


class Machine(models.Model):
    """A computer runs were executed on (hostname by default, ``--machine`` to name it)."""

    name = models.CharField(max_length=200, unique=True)
    created = models.DateTimeField(auto_now_add=True)

    def __str__(self):
        return self.name


class Target(models.Model):
    """A named build of a DEM code at a git revision (``targets/NAME.json``)."""

    name = models.CharField(max_length=200, unique=True)
    definition = models.JSONField(default=dict)
    reference = models.ForeignKey("self", null=True, blank=True, on_delete=models.SET_NULL,
                                  related_name="referenced_by")
    updated = models.DateTimeField(auto_now=True)

    def __str__(self):
        return self.name


class Build(models.Model):
    """A build of a target at one resolved commit; counts only once ``status == complete``."""

    class Status(models.TextChoices):
        BUILDING = "building"
        COMPLETE = "complete"
        FAILED = "failed"

    target = models.ForeignKey(Target, on_delete=models.CASCADE, related_name="builds")
    machine = models.ForeignKey(Machine, on_delete=models.CASCADE, related_name="builds")
    revision = models.CharField(max_length=200, help_text="revision as asked (tag, branch, commit, HEAD)")
    commit = models.CharField(max_length=64, help_text="resolved commit (or binary digest for system targets)")
    definition_hash = models.CharField(max_length=64)
    committed_at = models.DateTimeField(null=True, blank=True)
    commit_message = models.TextField(blank=True)
    status = models.CharField(max_length=16, choices=Status.choices, default=Status.BUILDING)
    executable = models.TextField(blank=True, help_text="command prefix that runs the built engine (JSON list)")
    environment = models.JSONField(default=dict, blank=True,
                                   help_text="extra environment variables the engine needs (e.g. PYTHONPATH)")
    folder = models.TextField(blank=True)
    log = models.TextField(blank=True)
    started = models.DateTimeField(null=True, blank=True)
    finished = models.DateTimeField(null=True, blank=True)
    current = models.BooleanField(default=False, db_index=True,
                                  help_text="the build of the commit the target's revision resolved to when "
                                            "last asked (one per target and machine; harness.execution.builds)")
    objects = BuildQuerySet.as_manager()

    details = models.JSONField(default=dict, blank=True,
                               help_text="what the recipe recorded: duration_s, error (first error line), "
                                         "compiler, jobs, commands, cmake_options, env, patches, ccache")

    class Meta:
        constraints = [models.UniqueConstraint(fields=["target", "machine", "commit", "definition_hash"],
                                               name="unique_build")]

    def __str__(self):
        return f"{self.target.name}@{self.commit[:10]}"

    @property
    def key(self) -> str:
        """Short folder-safe name of the build: commit and definition hash prefixes."""
        return f"{self.commit[:12]}-{self.definition_hash[:8]}"

    @property
    def duration(self) -> float | None:
        """Build time in seconds (None while building or for builds recorded without it)."""
        if (self.details or {}).get("duration_s") is not None:
            return self.details["duration_s"]
        if self.started and self.finished:
            return (self.finished - self.started).total_seconds()
        return None


class TestCase(models.Model):
    """A folder with a run.config, identified by its path relative to the test case root (``a/b/c``)."""

    path = models.CharField(max_length=500, unique=True)

    def __str__(self):
        return self.path


def _choices(name: str, labels: dict) -> type[models.TextChoices]:
    """Django choices of a ``{value: label}`` table, each member named by its value in upper case."""
    return models.TextChoices(name, [(value.upper() or "NONE", (value, label)) for value, label in labels.items()])


class Run(models.Model):
    """One execution of one run configuration by one build on one machine."""

    #: the record's states and failure reasons (harness.config.record), members named by their upper-case
    #: value (Run.State.FAILED; the empty reason is Run.FailureReason.NONE)
    State = _choices("State", STATE_LABELS)
    FailureReason = _choices("FailureReason", FAILURE_LABELS)

    class Consistency(models.TextChoices):
        NOT_CHECKED = "", "not checked"
        PERFECT = "perfect"
        GOOD = "good"
        INCONSISTENT = "inconsistent"
        NO_REFERENCE = "no_reference", "no reference run"

    machine = models.ForeignKey(Machine, on_delete=models.CASCADE, related_name="runs")
    target = models.ForeignKey(Target, on_delete=models.CASCADE, related_name="runs")
    build = models.ForeignKey(Build, on_delete=models.CASCADE, related_name="runs")
    testcase = models.ForeignKey(TestCase, on_delete=models.CASCADE, related_name="runs")
    name = models.CharField(max_length=200, help_text="run configuration name from run.config")
    testcase_hash = models.CharField(max_length=64, blank=True, default="", db_index=True,
                                     help_text="sha256 of the test case content as run: run.config entry, "
                                               "variables, every file copied into the run folder")
    state = models.CharField(max_length=32, choices=State.choices, default=State.NOT_EXECUTED, db_index=True)
    failure_reason = models.CharField(max_length=32, choices=FailureReason.choices, blank=True, default="")
    failure_message = models.TextField(blank=True)
    config = models.JSONField(default=dict, help_text="the run configuration entry as run")
    folder = models.TextField(blank=True, help_text="absolute path of the run folder")
    command = models.JSONField(default=list)
    exit_code = models.IntegerField(null=True, blank=True)
    started = models.DateTimeField(null=True, blank=True)
    finished = models.DateTimeField(null=True, blank=True)
    wall_time = models.FloatField(null=True, blank=True, help_text="s, engine process wall time")
    stepping_time = models.FloatField(null=True, blank=True,
                                      help_text="s, the engine's own time stepping (its loop time: no start-up, "
                                                "no JIT compilation); what speed trends and comparisons use")
    timing = models.JSONField(default=dict, help_text="s per category: pair, neigh, comm, modify, output, other, total")
    breakdown = models.JSONField(default=dict, blank=True,
                                 help_text="the timing breakdown in the harness' sections, s with min/avg/max over "
                                           "ranks where the code prints them, ranks and load imbalance "
                                           "(harness.analysis.breakdown)")
    profile = models.CharField(max_length=200, blank=True, default="",
                               help_text="the run's sampling profile as folded stacks, a file in its run folder "
                                         "(harness.execution.profiles); blank: not profiled")
    warning_count = models.IntegerField(default=0)
    consistency = models.CharField(max_length=16, choices=Consistency.choices, blank=True, default="")
    consistency_min = models.FloatField(null=True, blank=True, help_text="lowest C over all quantities")
    reference_run = models.ForeignKey("self", null=True, blank=True, on_delete=models.SET_NULL,
                                      related_name="compared_runs")
    replaced = models.BooleanField(default=False, help_text="a newer run of the same build and test case "
                                   "(other content, or a forced rebuild) took its place: it stays outdated")
    created = models.DateTimeField(auto_now_add=True)
    updated = models.DateTimeField(auto_now=True)

    objects = RunQuerySet.as_manager()

    class Meta:
        constraints = [models.UniqueConstraint(fields=["machine", "build", "testcase", "name", "testcase_hash"],
                                               name="unique_run_per_build_and_content")]
        indexes = [models.Index(fields=["machine", "target", "state"])]

    def __str__(self):
        return f"{self.target.name}:{self.testcase.path}/{self.name}"

    @property
    def short_hash(self) -> str:
        """The test case hash as shown in tables and reports (10 hex digits)."""
        return self.testcase_hash[:10]


class Series(models.Model):
    """Post-processed data of a run: thermo, a declared CSV plot, VTK aggregates or a textfile's numbers.

    ``columns`` maps a column name to its list of values; all columns have the same length.
    """

    class Kind(models.TextChoices):
        THERMO = "thermo"
        PLOT = "plot"
        VTK = "vtk"
        TEXTFILE = "textfile"

    run = models.ForeignKey(Run, on_delete=models.CASCADE, related_name="series")
    kind = models.CharField(max_length=16, choices=Kind.choices)
    name = models.CharField(max_length=200)
    x_column = models.CharField(max_length=200, blank=True, help_text="abscissa column (thermo: step)")
    columns = models.JSONField(default=dict)
    meta = models.JSONField(default=dict, help_text="units, title, axis labels as declared")

    class Meta:
        constraints = [models.UniqueConstraint(fields=["run", "kind", "name"], name="unique_series")]


class ConsistencyResult(models.Model):
    """Version consistency of one quantity of a run against the reference run (thesis eqs. 4.2-4.4)."""

    run = models.ForeignKey(Run, on_delete=models.CASCADE, related_name="consistency_results")
    reference_run = models.ForeignKey(Run, on_delete=models.CASCADE, related_name="+")
    series_kind = models.CharField(max_length=16)
    series_name = models.CharField(max_length=200)
    quantity = models.CharField(max_length=200)
    value = models.FloatField(null=True, blank=True, help_text="C = 1 - max_k Delta_k")
    level = models.CharField(max_length=16, help_text="perfect, good, inconsistent, length_mismatch, missing")
    epsilon = models.FloatField(null=True, blank=True)
    first_bad_step = models.FloatField(null=True, blank=True, help_text="first abscissa value outside the band")
    message = models.TextField(blank=True)
    checked = models.DateTimeField(auto_now=True)

    class Meta:
        constraints = [models.UniqueConstraint(fields=["run", "series_kind", "series_name", "quantity"],
                                               name="unique_consistency_quantity")]


class Override(models.Model):
    """A reviewer's decision to accept an inconsistency or a failure, with the reason kept."""

    run = models.ForeignKey(Run, on_delete=models.CASCADE, related_name="overrides")
    quantity = models.CharField(max_length=200, blank=True, help_text="blank: the whole run")
    user = models.ForeignKey(settings.AUTH_USER_MODEL, null=True, on_delete=models.SET_NULL)
    reason = models.TextField()
    created = models.DateTimeField(auto_now_add=True)
