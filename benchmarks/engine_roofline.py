"""A roofline-style limit of the settling scene on this machine, and how far each phase of the engine is from it.

Measured here, on one core, with small compiled loops (Numba, as the engine), in CPU seconds of the process (so
that the waiting of a loaded machine does not count):
- memory bandwidth: the STREAM triad a = b + s c over arrays far larger than the caches (GB/s, counting the
  write-allocate read of a: 32 B per element);
- throughput of the scalar operations the contact code is made of: multiply-add pairs, divisions and square
  roots (8 independent chains each, so that latency does not count);
- and of divisions and square roots in a loop LLVM vectorizes (arrays in L1), as the pair pass's contact sweep
  is compiled (engine/kernels.py PAIR_FORCES): the compute limit of a contact uses this rate;
- the rate of indexed loads and stores from the caches: a loop that copies 8 doubles of a row picked by an index
  array into 8 columns (9 loads and 8 stores per row, what the pair pass's sweeps do per pair; about one store
  per cycle here, whatever the order of the index or the form of the loop). At 10,000 particles every array of
  the scene fits in the caches (about 3 MB), so this rate, not the memory bandwidth, bounds the sweeps that move
  data: the memory limit of the pair and neighbor phases uses it. A phase near 1.0 of it is bound by the loads
  and stores of its design (for the pair pass: the columns of its three sweeps), not by arithmetic.

The contact counts come from the engine itself: a settling run of N spheres (engine/examples/settling.json, one
thread) gives its contacts (thermo `contacts`), listed pairs (the neighbor list of a restart file written at the
end) per particle and neighbor rebuilds (log.dem), and its timing.json phases (pair, neigh, modify; wall clock,
scaled by the loop's CPU / wall ratio, timing.json `cpu` / `total`, so that the load of a shared machine is
taken out as far as it can be). The work, counted in the generated kernels (engine/kernels.py PAIR_FORCES,
Hertz + tangential history, six planes) and engine/neighbor.py:

- a listed pair (the contact-finding sweep, every pair): 10 flops; 5 loads (j, x[j], radius[j]) and 8 stores
  (the pair's indices, distance vector and square, and its slot among the pairs apart); a pair apart then
  reads its `live` byte, and its history only where that byte is 1 (engine/neighbor.py NeighborList);
- a contact (gather, force, sums sweeps): ~130 flops, 5 square roots and 6 divisions (vectorized); ~80 loads and
  ~55 stores (24 columns gathered, read back and 15 written by the force sweep, 12 sums added in list order,
  the history written back);
- per particle and step (integration, gravity, plane bits): ~60 flops, and every particle array streamed once or
  twice: ~400 B, from memory once the particles no longer fit in the caches;
- a neighbor rebuild, per particle: ~32 candidates tested (half of the 27 cells of 2 r + skin around it, at the
  bed's packing: 10 flops, 5 loads, 1 store each), the rows sorted and the history carried (~3 loads, 2 stores
  per listed pair and history double), the particle arrays re-ordered (~200 B read and written); amortised over
  the steps between rebuilds.

The limit of a phase is the larger of its compute time (flops at the measured multiply-add rate plus
divisions and roots at theirs) and its memory time (bytes at the measured bandwidth, or cache loads and stores
at the measured indexed rate).

    python benchmarks/engine_roofline.py                      # N = 10000, 30000 steps (the whole settling)
    python benchmarks/engine_roofline.py --particles 10000 --steps 3000
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

REPO = Path(__file__).resolve().parents[1]

#: per listed pair (distance test), per contact, per particle-step, per particle and rebuild: (flops, divisions +
#: square roots, bytes from memory, cache loads + stores)
PAIR_TEST = (10, 0, 0, 13)
CONTACT = (130, 11, 0, 135)
PARTICLE = (60, 0, 400, 0)
REBUILD = (32 * 10 + 60, 0, 400, 32 * 6 + 5.4 * 20)


@njit(cache=True)
def _triad(a, b, c, s):
    for i in range(a.shape[0]):
        a[i] = b[i] + s * c[i]


@njit(cache=True)
def _fma_chains(n, x):
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = x
    for _ in range(n):
        a0 = a0 * 0.999999 + 1e-7
        a1 = a1 * 0.999998 + 1e-7
        a2 = a2 * 0.999997 + 1e-7
        a3 = a3 * 0.999996 + 1e-7
        a4 = a4 * 0.999995 + 1e-7
        a5 = a5 * 0.999994 + 1e-7
        a6 = a6 * 0.999993 + 1e-7
        a7 = a7 * 0.999992 + 1e-7
    return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7


@njit(cache=True)
def _div_sqrt_chains(n, x):
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = x
    for _ in range(n):
        a0 = math.sqrt(a0 + 1.0)
        a1 = 1.5 / (a1 + 1.0)
        a2 = math.sqrt(a2 + 2.0)
        a3 = 2.5 / (a3 + 1.0)
        a4 = math.sqrt(a4 + 3.0)
        a5 = 3.5 / (a5 + 1.0)
        a6 = math.sqrt(a6 + 4.0)
        a7 = 4.5 / (a7 + 1.0)
    return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7


@njit(cache=True, error_model="numpy")
def _div_sqrt_vector(a, out, rounds):
    for _ in range(rounds):
        for i in range(a.shape[0]):
            out[i] = math.sqrt(a[i]) + 1.5 / a[i]


@njit(cache=True)
def _indexed_copy(index, rows, columns, rounds):
    for _ in range(rounds):
        for q in range(index.shape[0]):
            i = index[q]
            for c in range(8):
                columns[c, q] = rows[i, c]


def best_of(fn, repeat=5) -> float:
    """The shortest of `repeat` calls of fn, in CPU seconds of this process."""
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def machine() -> dict:
    n = 1 << 24  # 3 x 128 MB, far beyond the caches
    a, b, c = np.zeros(n), np.ones(n), np.ones(n)
    _triad(a, b, c, 3.0)
    bandwidth = 32 * n / best_of(lambda: _triad(a, b, c, 3.0))
    steps = 20_000_000
    _fma_chains(10, 1.0)
    flops = 16 * steps / best_of(lambda: _fma_chains(steps, 1.0))
    _div_sqrt_chains(10, 1.0)
    roots = 8 * steps / best_of(lambda: _div_sqrt_chains(steps, 1.0))
    a, out, rounds = np.linspace(1.0, 2.0, 2048), np.zeros(2048), 5000
    _div_sqrt_vector(a, out, 1)
    vector = 2 * a.shape[0] * rounds / best_of(lambda: _div_sqrt_vector(a, out, rounds))
    # rows picked at random among 10,000 (the scene's particles, in the caches), 1032 at a time (a pair sweep)
    index = np.random.default_rng(1).integers(0, 10000, 1032)
    rows, columns, rounds = np.ones((10000, 8)), np.zeros((8, 1032)), 2000
    _indexed_copy(index, rows, columns, 1)
    memops = 17 * index.shape[0] * rounds / best_of(lambda: _indexed_copy(index, rows, columns, rounds))
    return {"bandwidth": bandwidth, "flops": flops, "div_sqrt": roots, "div_sqrt_vector": vector, "memops": memops}


def engine_counts(n: int, steps: int) -> dict:
    """Pairs and contacts per particle at the end of a settling run, and its timing.json."""
    with tempfile.TemporaryDirectory() as tmp:
        half_width = 0.03 * math.sqrt(n / 10000)
        script = json.loads((REPO / "engine" / "examples" / "settling.json").read_text())
        for command in script:  # thermo with the contacts
            if command.get("property") == "thermo":
                command["columns"] = ["contacts"]
        script.append({"command": "create", "object": "restart", "file": "end.restart"})  # the neighbor list
        (Path(tmp) / "scene.json").write_text(json.dumps(script))
        variables = dict(N=n, SEED=1, HALF_WIDTH=half_width, HEIGHT=0.2, DUMP_EVERY=10 ** 9, SETTLE_STEPS=steps,
                         MEASURE_STEPS=0)
        cmd = [sys.executable, "-m", "engine", "-in", "scene.json"] + [
            a for k, v in variables.items() for a in ("-var", k, str(v))]
        env = dict(os.environ, PYTHONPATH=str(REPO), NUMBA_NUM_THREADS="1")
        subprocess.run(cmd, cwd=tmp, env=env, check=True, capture_output=True)
        rows = (Path(tmp) / "thermo.csv").read_text().split()
        header = rows[0].split(",")
        last = dict(zip(header, rows[-1].split(",")))
        timing = json.loads((Path(tmp) / "timing.json").read_text())
        with np.load(Path(tmp) / "end.restart", allow_pickle=False) as restart:
            listed = len(restart["nbr_j"])
        rebuilds = sum(int(line.split(" rebuilds)")[0].rsplit("(", 1)[1])  # every run's Loop time line
                       for line in (Path(tmp) / "log.dem").read_text().splitlines() if " rebuilds)" in line)
    particles = int(last["atoms"])
    return {"particles": particles, "contacts": int(last["contacts"]) / particles, "pairs": listed / particles,
            "timing": timing, "rebuilds": rebuilds}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--particles", type=int, default=10000)
    parser.add_argument("--steps", type=int, default=30000)
    args = parser.parse_args()
    m = machine()
    print(f"this machine, one core: STREAM triad {m['bandwidth'] / 1e9:.1f} GB/s, multiply-add "
          f"{m['flops'] / 1e9:.2f} Gflop/s, divisions/square roots {m['div_sqrt'] / 1e9:.3f} G/s scalar, "
          f"{m['div_sqrt_vector'] / 1e9:.3f} G/s vectorized, indexed loads + stores from the caches "
          f"{m['memops'] / 1e9:.2f} G/s")
    counts = engine_counts(args.particles, args.steps)
    contacts = counts["contacts"]
    pairs = counts["pairs"]
    timing = counts["timing"]
    ps = timing["particle_steps"]
    cpu_share = timing["cpu"] / timing["total"]  # the loop's CPU / wall: the phases' wall times scaled by it
    steps_per_rebuild = timing["steps"] / max(counts["rebuilds"], 1)

    def limit(work, times, roots_rate=m["div_sqrt"]):
        flops, roots, nbytes, memops = work
        compute = (flops / m["flops"] + roots / roots_rate) * times
        memory = (nbytes / m["bandwidth"] + memops / m["memops"]) * times
        return compute, memory

    c_pair, m_pair = limit(PAIR_TEST, pairs)
    c_contact, m_contact = limit(CONTACT, contacts, m["div_sqrt_vector"])  # the vectorized contact sweep
    print(f"settling scene, {counts['particles']} spheres, {args.steps} steps: {contacts:.2f} contacts and "
          f"{pairs:.2f} listed pairs per particle (half list) at the end, {counts['rebuilds']} rebuilds (one per "
          f"{steps_per_rebuild:.0f} steps); loop CPU / wall {cpu_share:.2f}")
    print(f"{'phase':<10} {'CPU ns/p-step':>13} {'compute limit':>13} {'memory limit':>12} {'measured/limit':>14}")
    phases = {"pair": (c_pair + c_contact, m_pair + m_contact),
              "modify": limit(PARTICLE, 1.0),
              "neigh": limit(REBUILD, 1.0 / steps_per_rebuild)}
    for name, (compute, memory) in phases.items():
        measured = timing[name] * cpu_share / ps * 1e9
        bound = max(compute, memory) * 1e9
        print(f"{name:<10} {measured:>13.1f} {compute * 1e9:>13.1f} {memory * 1e9:>12.1f} {measured / bound:>14.2f}")
    print(f"{'(pairs)':<10} {'':>13} {c_pair * 1e9:>13.1f} {m_pair * 1e9:>12.1f}   the contact-finding sweep")
    print(f"{'(contacts)':<10} {'':>13} {c_contact * 1e9:>13.1f} {m_contact * 1e9:>12.1f}   gather, force, sums")
    total = (timing["pair"] + timing["neigh"] + timing["modify"]) * cpu_share
    bound = sum(max(c, mm) for c, mm in phases.values()) * ps
    print(f"{'total':<10} {total / ps * 1e9:>13.1f} ns per particle-step; limit {bound / ps * 1e9:.1f} ns "
          f"(measured/limit {total / bound:.2f})")


if __name__ == "__main__":
    main()
