"""A roofline-style limit of the settling scene on this machine, and how far each phase of the engine is from it.

Measured here, on one core, with small compiled loops (Numba, as the engine):
- memory bandwidth: the STREAM triad a = b + s c over arrays far larger than the caches (GB/s, counting the
  write-allocate read of a: 32 B per element);
- throughput of the scalar operations the contact code is made of: multiply-add pairs, divisions and square
  roots (8 independent chains each, so that latency does not count);
- and of divisions and square roots in a loop LLVM vectorizes (arrays in L1), as the pair pass's contact sweep
  is compiled (engine/kernels.py PAIR_FORCES): the compute limit of a contact uses this rate.

The contact counts come from the engine itself: a settling run of N spheres (engine/examples/settling.json, one
thread) gives its contacts (thermo `contacts`) and listed pairs (the neighbor list of a restart file written at
the end) per particle, and its timing.json phases (pair, neigh, modify per particle-step). The work per pair and per
particle, counted in the generated kernels (engine/kernels.py, Hertz + tangential history, five planes):

- a listed pair not in contact: 10 flops; loads x[j], radius[j] and the index (36 B, from the caches: the
  partner was sorted next to i) and, for history, a store of 3 zeros (24 B);
- a contact: ~130 flops, 5 square roots, 6 divisions; 176 B of the partner and its history (caches);
- per particle and step (integration, gravity, plane bits, pair-loop head and sums): ~60 flops, and every
  particle array streamed once or twice: x, v, omega read and written, f, torque read and written, radius,
  mass, inverses, type, x_build read, neighbor rows (start, j, history): ~400 B from memory once the
  particles no longer fit in the caches.

The limit of a phase is the larger of its compute time (flops at the measured multiply-add rate plus
divisions and roots at theirs) and its memory time (bytes at the measured bandwidth).

    python benchmarks/engine_roofline.py                      # N = 10000, 3000 steps
    python benchmarks/engine_roofline.py --particles 10000 --steps 30000
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

#: per listed pair (distance test), per contact, per particle-step: (flops, divisions + square roots, bytes)
PAIR_TEST = (10, 0, 60)
CONTACT = (130, 11, 176)
PARTICLE = (60, 0, 400)


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


def best_of(fn, repeat=5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
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
    return {"bandwidth": bandwidth, "flops": flops, "div_sqrt": roots, "div_sqrt_vector": vector}


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
    particles = int(last["atoms"])
    return {"particles": particles, "contacts": int(last["contacts"]) / particles, "pairs": listed / particles,
            "timing": timing}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--particles", type=int, default=10000)
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args()
    m = machine()
    print(f"this machine, one core: STREAM triad {m['bandwidth'] / 1e9:.1f} GB/s, multiply-add "
          f"{m['flops'] / 1e9:.2f} Gflop/s, divisions/square roots {m['div_sqrt'] / 1e9:.3f} G/s scalar, "
          f"{m['div_sqrt_vector'] / 1e9:.3f} G/s vectorized")
    counts = engine_counts(args.particles, args.steps)
    contacts = counts["contacts"]
    pairs = counts["pairs"]
    timing = counts["timing"]
    ps = timing["particle_steps"]

    def limit(work, times, roots_rate=m["div_sqrt"]):
        flops, roots, nbytes = work
        compute = (flops / m["flops"] + roots / roots_rate) * times
        memory = nbytes * times / m["bandwidth"]
        return compute, memory

    c_pair, m_pair = limit(PAIR_TEST, pairs)
    c_contact, m_contact = limit(CONTACT, contacts, m["div_sqrt_vector"])  # the vectorized contact sweep
    c_part, m_part = limit(PARTICLE, 1.0)
    print(f"settling scene, {counts['particles']} spheres, {args.steps} steps: {contacts:.2f} contacts and "
          f"{pairs:.2f} listed pairs per particle (half list) at the end")
    print(f"{'phase':<10} {'measured ns/p-step':>18} {'compute limit':>13} {'memory limit':>12} {'measured/limit':>14}")
    phases = {"pair": (c_pair + c_contact, (m_pair + m_contact)),
              "modify": (c_part, m_part)}
    for name, (compute, memory) in phases.items():
        measured = timing[name] / ps * 1e9
        bound = max(compute, memory) * 1e9
        print(f"{name:<10} {measured:>18.1f} {compute * 1e9:>13.1f} {memory * 1e9:>12.1f} {measured / bound:>14.2f}")
    print(f"{'neigh':<10} {timing['neigh'] / ps * 1e9:>18.1f} (rebuilds: a cell sort and search per particle, "
          "amortised over the steps between rebuilds)")
    total = timing["pair"] + timing["neigh"] + timing["modify"]
    bound = sum(max(c, mm) for c, mm in phases.values()) * ps
    print(f"{'total':<10} {total / ps * 1e9:>18.1f} ns per particle-step; limit of pair + modify "
          f"{bound / ps * 1e9:.1f} ns (measured/limit {total / bound:.2f})")


if __name__ == "__main__":
    main()
