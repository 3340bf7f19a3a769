"""The order in which runs start when several go at once (harness.execution.scheduler.run_order): longest
chains of known runs first, unknown runs first of all and in turn from each build."""
from harness.execution.scheduler import Task, run_order
from harness.store.runrecord import RunSpec


def task(target: str, case: str, expected: float | None, commit: str = "c1", adapter: str = "dem",
         depends_on: tuple | None = None) -> Task:
    spec = RunSpec(machine="m", target=target, target_definition={}, build={"commit": commit}, testcase=case,
                   run="r", testcase_hash="", config={}, adapter=adapter, thermo_columns={}, environment={},
                   workspace="/w", folder=f"/w/{target}/{case}", source_folder="/c", files=[])
    return Task((target, case, "r", commit), spec, depends_on=depends_on, expected=expected)


def names(tasks: list[Task]) -> list[str]:
    return [t.key[1] for t in tasks]


def test_known_runs_go_longest_first():
    tasks = [task("dem", "short", 1.0), task("dem", "hopper", 290.0), task("dem", "middle", 20.0)]
    assert names(run_order(tasks)) == ["hopper", "middle", "short"]


def test_a_chain_goes_by_its_whole_length():
    """A 5 s run that a 100 s run waits for starts before a 50 s run: the chain is 105 s long."""
    head = task("dem", "restart/write", 5.0)
    tail = task("dem", "restart/read", 100.0, depends_on=head.key)
    alone = task("dem", "alone", 50.0)
    assert names(run_order([alone, tail, head])) == ["restart/write", "restart/read", "alone"]


def test_unknown_runs_go_first_in_turn_from_each_build():
    """A first run of everything: the runs of each build (engine version, code) alternate, each build's in its
    planned order; a chain with an unknown part is unknown."""
    tasks = [task("dem", "a1", None), task("dem", "a2", None), task("dem", "a3", None),
             task("dem-reference", "b1", None, commit="c0"), task("dem-reference", "b2", None, commit="c0"),
             task("liggghts", "l1", None, adapter="liggghts"),
             task("dem", "known", 500.0)]
    tasks.append(task("dem", "after-known", None, depends_on=tasks[-1].key))
    assert names(run_order(tasks)) == ["a1", "b1", "l1", "a2", "b2", "a3", "known", "after-known"]


def test_the_targets_of_one_build_take_turns_as_one():
    """dem and dem-crosscode at the same commit run the same engine: one build, one turn."""
    tasks = [task("dem", "x", None), task("dem-crosscode", "y", None), task("lammps", "z", None, adapter="lammps")]
    assert names(run_order(tasks)) == ["x", "z", "y"]
