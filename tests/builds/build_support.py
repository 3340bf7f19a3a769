"""Helpers for the build tests: tiny C++ CMake repositories and target files."""
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CMAKELISTS = """cmake_minimum_required(VERSION 3.13)
project(tiny CXX)
add_executable(tiny main.cpp other.cpp)
target_compile_definitions(tiny PRIVATE GREETING="${GREETING}")
"""
MAIN_CPP = """#include <cstdio>
const char *other();
#ifndef MARK
#define MARK "unmarked"
#endif
int main() { std::printf("%s %s %s\\n", GREETING, MARK, other()); return 0; }
"""
OTHER_CPP = 'const char *other() { return "v1"; }\n'


def git_repo(folder: Path):
    import git

    folder.mkdir(parents=True, exist_ok=True)
    repo = git.Repo.init(folder)
    with repo.config_writer() as config:
        config.set_value("user", "name", "Test")
        config.set_value("user", "email", "test@example.org")
    return repo


def commit_files(repo, files: dict, message: str, tag: str | None = None) -> str:
    root = Path(repo.working_tree_dir)
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    repo.git.add("-A")
    repo.index.commit(message)
    if tag:
        repo.create_tag(tag)
    return repo.head.commit.hexsha


def tiny_repo(folder: Path):
    """A C++ CMake program under ``src/`` (printing GREETING, MARK and other()) and a ``docs/`` folder the
    build does not need; tags v1 and v2 (other.cpp changed)."""
    repo = git_repo(folder)
    commit_files(repo, {"src/CMakeLists.txt": CMAKELISTS, "src/main.cpp": MAIN_CPP, "src/other.cpp": OTHER_CPP,
                        "docs/manual.txt": "not needed by the build\n"}, "v1", tag="v1")
    commit_files(repo, {"src/other.cpp": OTHER_CPP.replace("v1", "v2")}, "v2", tag="v2")
    return repo


def write_target(folder: Path, name: str, data: dict) -> Path:
    path = folder / "targets" / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return path


def tiny_target(repo, **extra) -> dict:
    return {"repository": str(repo.working_tree_dir), "recipe": "cmake", "source_folder": "src",
            "cmake_options": {"GREETING": "hello"}, "generated_executable": "tiny", **extra}


def harness(home: Path, targets: Path, *args, timeout=600, env=None, popen=False):
    command = [sys.executable, "-m", "harness.cli", "--machine", "m1", "--home", str(home), "--targets",
               str(targets), *args]
    environment = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    environment.pop("HARNESS_HOME", None)
    if popen:
        return subprocess.Popen(command, cwd=ROOT, env=environment, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
    return subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True, timeout=timeout)


# the fake engine of tests/harness behind a tiny C++ launcher: every commit is a real C++ build (a second)
FAKE_ENGINE = (ROOT / "tests" / "harness" / "fake_engine" / "__main__.py").read_text()
LAUNCHER = """#include <unistd.h>
#include <vector>
// runs the engine's Python source with the arguments given to this program
int main(int argc, char **argv) {
  std::vector<char *> args;
  args.push_back(const_cast<char *>(PYTHON));
  args.push_back(const_cast<char *>(ENGINE_MAIN));
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  execv(PYTHON, args.data());
  return 127;
}
"""
CMAKELISTS_LAUNCHER = """cmake_minimum_required(VERSION 3.13)
project(fake CXX)
add_executable(fake_engine launcher.cpp)
target_compile_definitions(fake_engine PRIVATE PYTHON="${PYTHON}"
                           ENGINE_MAIN="${CMAKE_CURRENT_SOURCE_DIR}/__main__.py")
"""
SCENE = json.dumps([{"command": "create", "heights": [1.0, 0.5]}, {"command": "run", "steps": 100, "every": 20}])
