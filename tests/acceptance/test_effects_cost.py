"""The cost figure the run summary shows for every run (what each effect of a scene costs)."""
from harness.execution.scheduler import cost_per_particle_step, summary_table
from harness.store.runrecord import RunRecord


def test_cost_per_particle_step_prefers_cpu_time():
    assert cost_per_particle_step({"cpu": 2.0, "total": 3.0, "particle_steps": 1_000_000}) == 2.0
    assert cost_per_particle_step({"total": 3.0, "particle_steps": 1_000_000}) == 3.0
    assert cost_per_particle_step({"total": 3.0}) is None  # e.g. a code that does not count particle-steps
    assert cost_per_particle_step({}) is None


def test_summary_table_has_the_cost_column():
    record = RunRecord(target="dem", machine="m", testcase="effects/blocks", run="1_normal", state="post_processed",
                       wall_time=1.5, timing={"cpu": 0.5, "particle_steps": 5_000_000})
    table = summary_table([record, record.model_copy(update={"run": "x", "timing": {}})])
    assert "us/particle-step" in table.splitlines()[0]
    assert table.splitlines()[2].rstrip().endswith("0.100")
    assert table.splitlines()[3].rstrip().endswith("-")
