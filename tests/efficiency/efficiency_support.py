"""A small real C++ particle code in a git repository, built by the make recipe and run through the generic
adapter, for the slowdown tests: its functions compute_pair_forces, build_neighbor_list and integrate are
what a profile sees; a commit can plant a busy loop in one of them."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


provenance = _load("provenance_support_for_efficiency", ROOT / "tests" / "reliability" / "provenance_support.py")
git_repo, commit_files, harness, rows = (provenance.git_repo, provenance.commit_files, provenance.harness,
                                         provenance.rows)

#: particles falling onto a floor with a linear spring; each step: neighbors every 10 steps, pair forces,
#: integration; thermo.csv every 100 steps; timings per phase on stdout, as "pair time 0.12 s" lines
PROGRAM = r"""
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

struct Particles { std::vector<double> z, v, f; };
static double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

__attribute__((noinline)) void build_neighbor_list(const Particles &p, std::vector<int> &pairs) {
    pairs.clear();
    for (size_t i = 0; i < p.z.size(); ++i)
        for (size_t j = i + 1; j < p.z.size(); ++j)
            if (std::fabs(p.z[i] - p.z[j]) < 0.05) { pairs.push_back(i); pairs.push_back(j); }
}

__attribute__((noinline)) void compute_pair_forces(Particles &p, const std::vector<int> &pairs) {
    for (size_t k = 0; k < p.z.size(); ++k) p.f[k] = -9.81;
    for (size_t k = 0; k + 1 < pairs.size(); k += 2) {
        int i = pairs[k], j = pairs[k + 1];
        double overlap = 0.01 - std::fabs(p.z[i] - p.z[j]);
        if (overlap > 0) {
            double s = p.z[i] > p.z[j] ? 1 : -1;
            p.f[i] += 1e4 * overlap * s; p.f[j] -= 1e4 * overlap * s;
        }
    }
    for (size_t k = 0; k < p.z.size(); ++k) if (p.z[k] < 0) p.f[k] += -1e4 * p.z[k];
    SLOWDOWN
}

__attribute__((noinline)) void integrate(Particles &p, double dt) {
    for (size_t k = 0; k < p.z.size(); ++k) { p.v[k] += p.f[k] * dt; p.z[k] += p.v[k] * dt; }
}

int main(int argc, char **argv) {
    int n = 400, steps = STEPS;
    Particles p; p.z.resize(n); p.v.resize(n); p.f.resize(n);
    for (int i = 0; i < n; ++i) p.z[i] = 0.02 * i + 0.01;
    std::vector<int> pairs;
    FILE *thermo = std::fopen("thermo.csv", "w");
    std::fprintf(thermo, "step,atoms,ke,rke\n");
    double t_pair = 0, t_neigh = 0, t_other = 0, start = now();
    for (int step = 0; step <= steps; ++step) {
        double t0 = now();
        if (step % 10 == 0) build_neighbor_list(p, pairs);
        double t1 = now();
        compute_pair_forces(p, pairs);
        double t2 = now();
        integrate(p, 1e-4);
        if (step % 100 == 0) {
            double ke = 0; for (int i = 0; i < n; ++i) ke += 0.5 * p.v[i] * p.v[i];
            std::fprintf(thermo, "%d,%d,%.12g,0\n", step, n, ke);
        }
        t_neigh += t1 - t0; t_pair += t2 - t1; t_other += now() - t2;
    }
    std::fclose(thermo);
    std::printf("Loop time %.6f s\npair time %.6f s\nneighbor time %.6f s\nother time %.6f s\n",
                now() - start, t_pair, t_neigh, t_other);
    return 0;
}
"""

#: a busy loop that makes the pair forces about six times as costly (the run about 2.5 times), kept by the
#: volatile counter
BUSY_LOOP = "for (volatile long spin = 0; spin < 150000; ++spin) {}"

MAKEFILE = ("mini: mini.cpp\n\tg++ -O1 -g -fno-omit-frame-pointer -fno-inline -o mini mini.cpp\n")

ADAPTER = {
    "description": "the small C++ code of tests/efficiency",
    "command": ["{executable}", "{script}"],
    "log": "stdout.txt",
    "thermo": {"csv": "thermo.csv"},
    "timing": {"total": "^Loop time (\\S+) s", "pair": "^pair time (\\S+) s", "neigh": "^neighbor time (\\S+) s",
               "other": "^other time (\\S+) s"},
}


def program(slow: bool = False, steps: int = 4000) -> str:
    return PROGRAM.replace("SLOWDOWN", BUSY_LOOP if slow else "").replace("STEPS", str(steps))


def make_code_project(tmp_path: Path, commits: int = 6, slow_at: int = 3, profile: bool = True) -> dict:
    """A repository with the code at ``good`` and ``commits`` later commits; commit ``slow_at`` (0-based) plants
    the busy loop in compute_pair_forces. The target ``mini`` builds it with make and runs cases/fall."""
    repo = git_repo(tmp_path / "repo")
    entry = {"name": "fall", "script": "in.fall"}
    if profile:
        entry["profile"] = {"call_graph": "fp", "frequency": 999}
    commit_files(repo, {"src/mini.cpp": program(), "src/Makefile": MAKEFILE, "cases/fall/in.fall": "fall\n",
                        "cases/fall/run.config": json.dumps({"runs": [entry]})}, "start", tag="good")
    shas = []
    for i in range(commits):
        files = {"NOTES.txt": f"note {i}\n"}
        if i == slow_at:
            files["src/mini.cpp"] = program(slow=True)
        shas.append(commit_files(repo, files, f"change {i}" + (" (pair forces)" if i == slow_at else "")))
    adapter = tmp_path / "mini-adapter.json"
    adapter.write_text(json.dumps(ADAPTER))
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "mini.json").write_text(json.dumps({
        "repository": str(repo.working_tree_dir), "revision": "HEAD", "recipe": "make", "source_folder": "src",
        "make_target": "mini", "generated_executable": "mini", "engine": f"generic:{adapter}",
        "testcases": ["cases"], "testcases_revision": "working-tree"}))
    return {"repo": repo, "targets": targets, "home": tmp_path / "home", "commits": shas}
