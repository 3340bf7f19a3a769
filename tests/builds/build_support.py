"""Helpers for the build tests: tiny C++ CMake repositories and target files (the harness process and git
repositories: tests/harness_process.py)."""
import json
from pathlib import Path

import harness_process
from harness_process import PROJECT as ROOT
from harness_process import commit_files, git_repo, project_env  # noqa: F401  (the build tests import them from here)

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
    """``harness_process.harness`` as machine m1 with this project first on PYTHONPATH; the exit code is
    the caller's to check."""
    return harness_process.harness(home, *args, targets=targets, machine="m1", check=False, timeout=timeout,
                                   env=project_env(**(env or {})), popen=popen)


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
