"""Reading run folders: which file is the script, log, output; downloads stay inside the folder."""
from types import SimpleNamespace

from webfrontend.runfiles import RunFolder


def folder_with(tmp_path, config, files, engine="dem"):
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    target = SimpleNamespace(definition={"engine": engine})
    return RunFolder(SimpleNamespace(folder=str(tmp_path), config=config, target=target))


def test_script_per_engine_family_and_liggghts_log(tmp_path):
    rf = folder_with(tmp_path, {"script": {"dem": "scene.json", "liggghts": "in.scene"}},
                     {"in.scene": "run 100\n", "log.liggghts": "Loop time\n", "log.dem": "not this engine\n",
                      "stdout.txt": "out\n"}, engine="liggghts")
    texts = rf.texts()
    assert (texts["input script"].name, texts["input script"].text) == ("in.scene", "run 100\n")
    assert texts["log"].name == "log.liggghts"  # the LIGGGHTS adapter's log, not another engine's
    assert texts["stderr"] is None
    assert '"liggghts": "in.scene"' in texts["run configuration"].text


def test_long_text_is_cut_and_artifacts_sorted_naturally(tmp_path):
    rf = folder_with(tmp_path, {}, {"log.txt": "x" * 100, "post/dump_1000.vtk": "", "post/dump_500.vtk": "",
                                    "post/torque.csv": "t\n", "core": "binary"})
    cut = rf.read("log.txt", limit=10)
    assert (cut.text, cut.truncated) == ("x" * 10, True)
    assert [name for name, _ in rf.artifacts()] == ["log.txt", "post/dump_500.vtk", "post/dump_1000.vtk",
                                                   "post/torque.csv"]


def test_resolve_stays_inside(tmp_path):
    run_dir = tmp_path / "run"
    (tmp_path / "outside.txt").write_text("secret")
    rf = folder_with(run_dir, {}, {"log.txt": "ok"})
    (run_dir / "link").symlink_to(tmp_path / "outside.txt")
    assert rf.resolve("log.txt") == (run_dir / "log.txt").resolve()
    for bad in ("../outside.txt", "/etc/passwd", "link", "", "log.txt\x00", "."):
        assert rf.resolve(bad) is None, bad
    assert RunFolder(SimpleNamespace(folder="", config={}, target=None)).texts()["log"] is None
    assert rf.resolve("x" * 5000) is None  # too long for the file system: no such file, not an error


def test_log_named_by_the_targets_engine_adapter(tmp_path):
    from harness.adapters import get_adapter

    files = {"log.dem": "bundled engine log\n", "log.liggghts": "LIGGGHTS log\n", "log.txt": "a stray file\n"}
    for engine in ("dem", "liggghts"):
        texts = folder_with(tmp_path / engine, {}, files, engine=engine).texts()
        assert texts["log"].name == get_adapter(engine).log_file()
    # a target definition without "engine" is the bundled engine's (harness/config/targets.py)
    rf = RunFolder(SimpleNamespace(folder=str(tmp_path / "dem"), config={}, target=SimpleNamespace(definition={})))
    assert rf.texts()["log"].text == "bundled engine log\n"
    unknown = folder_with(tmp_path / "other", {}, files, engine="no-such-engine")
    assert unknown.texts()["log"] is None  # an adapter this machine lacks: no guessing
