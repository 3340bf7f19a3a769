"""The pair pass and the neighbor rebuild of the engine at two revisions, alone, on the settled bed, side by side.

    python benchmarks/engine_pair_loop.py [--base main] [--new worktree] [--n 10000] [--settle 30000]
                                          [--calls 400] [--repeat 5] [--threads 1] [--bed FILE]

The settling scene (engine/examples/settling.json: N spheres of r = 1.5 mm, six planes, Hertz + tangential
history, gravity) is poured and settled for SETTLE steps by the new engine (30,000: the end of the 30,000-step
scene of benchmarks/engine_vs_liggghts.py, about 5.3 listed pairs and 2.2 contacts per particle) and written to
a restart file (--bed FILE: read from FILE if it exists, else written there too, to save the settling next
time). Each
revision then reads it in a process of its own and calls its compiled kernels directly, on the same particles:
the pair pass (`pair_forces`, engine/kernels.py PAIR_FORCES) CALLS times (each from the same forces and
contact history) and the neighbor rebuild
(engine/neighbor.py `rebuild`) CALLS/20 times, timed in CPU seconds of the process (`time.process_time`, so
that the waiting of a loaded machine does not count; with --threads 2, CPU seconds of both threads). The two
revisions alternate within each repetition so that the load of a shared machine hits both alike. Printed: ns per
particle per call for each, and the median ratio new / base.

The forces the pair pass leaves (f, torque, history and the partners' reaction rows after the first call: what
the particle pass reads of them, engine/kernels.py GATHER) are compared between the revisions byte for byte:
"same forces" must say True for a change that keeps the engine's results. With several threads only the history
is compared: since the boundary band (engine/neighbor.py boundary_band) the pass leaves most partners' shares in
their forces, not in reaction rows, so the arrays differ from an older revision's by design (the totals the
particle pass forms do not: tests/engine/test_parallel.py, benchmarks/engine_identical.py).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from engine_identical import export_engine
from engine_particle_pass import scripts

#: runs in the exported engine's own process: reads the bed, times its kernels, prints one JSON line
PROBE = r'''
import hashlib, json, sys, time
import numpy as np
from engine.log import Log
from engine.simulation import Simulation
from engine.script import load_script, substitute
from engine import runner
from engine.neighbor import lost_record

calls, threads = int(sys.argv[1]), int(sys.argv[2])
np.seterr(all="ignore")
sim = Simulation(Log(None, echo=False), threads=threads)
variables = {"STEPS": "0"}
for index, raw in enumerate(load_script("measure.json", variables), start=1):
    sim.execute(substitute(raw, variables, "measure.json"), index, "measure.json")
kernel = runner._Kernel(sim, threads)
m = kernel.module
c = kernel.constants
box = c.hi - c.lo
s, n, nbr = sim.state, sim.n, sim.nbr
lost = lost_record(n)
n, nbr = m.rebuild(s, n, nbr, c.lo, c.hi, c.periodic, c.skin, sim.step, lost, c.history_transfer)
f0, t0_, h0 = s.f.copy(), s.torque.copy(), nbr.hist.copy()
# several threads: a revision with the boundary band (engine/neighbor.py start_band) computes it before the pass
start_band = getattr(m, "start_band", None) if threads > 1 else None
if start_band is not None:
    from engine.kernels import PAIR_BLOCK
    start_band(nbr, n, PAIR_BLOCK, s.f, s.torque)
    f0, t0_ = s.f.copy(), s.torque.copy()
m.pair_forces(s, n, nbr, kernel.pp, c.dt, c.characteristic_velocity, box)  # compiles or loads
# what the particle pass reads of the pair pass' output: a reaction row only where its pair touches, f and
# torque (several threads) only of a particle with a contact as i, f + 0.0 (one thread); a revision without
# `touch` and `own` (older) wrote zeros there
f_out, t_out, rows = s.f + 0.0, s.torque + 0.0, nbr.reaction.copy()
if hasattr(nbr, "touch"):
    rows[nbr.touch == 0] = 0.0
if hasattr(nbr, "own") and threads > 1:
    f_out[nbr.own == 0] = 0.0
    t_out[nbr.own == 0] = 0.0
digest = hashlib.sha256(f_out.tobytes() + t_out.tobytes() + nbr.hist.tobytes() + rows.tobytes()).hexdigest()
if threads > 1:  # the band changed what the pass leaves for the particle pass on several threads: the history only
    digest = hashlib.sha256(nbr.hist.tobytes()).hexdigest()
pair = 0.0
for _ in range(calls):  # every call from the same forces and history: the same work each time
    s.f[:] = f0
    s.torque[:] = t0_
    nbr.hist[:] = h0
    t = time.process_time()
    m.pair_forces(s, n, nbr, kernel.pp, c.dt, c.characteristic_velocity, box)
    pair += time.process_time() - t
pair /= calls * n
rebuilds = max(1, calls // 20)
t = time.process_time()
for _ in range(rebuilds):
    n, nbr = m.rebuild(s, n, nbr, c.lo, c.hi, c.periodic, c.skin, sim.step, lost, c.history_transfer)
neigh = (time.process_time() - t) / rebuilds / n
print(json.dumps(dict(pair=pair, neigh=neigh, digest=digest, pairs=len(nbr.j) / n)))
'''


def probe(engine: Path, folder: Path, calls: int, threads: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(engine), "NUMBA_NUM_THREADS": str(threads)}
    proc = subprocess.run([sys.executable, "-c", PROBE, str(calls), str(threads)], cwd=folder, env=env,
                          capture_output=True, text=True, check=False)
    if proc.returncode:
        raise SystemExit(f"probe failed in {folder}: {proc.stderr.strip()[-800:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main")
    parser.add_argument("--new", default="worktree")
    parser.add_argument("--n", type=int, default=10000)
    parser.add_argument("--settle", type=int, default=30000)
    parser.add_argument("--bed", type=Path, help="restart file of the settled bed: read if it exists, else kept")
    parser.add_argument("--calls", type=int, default=400)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="engine_pair_") as tmp:
        root = Path(tmp)
        engines = {side: export_engine(rev, root / f"engine_{side}") for side, rev in
                   (("base", args.base), ("new", args.new))}
        scripts(root)
        half_width = round(0.03 * (args.n / 10000) ** 0.5, 6)
        if args.bed and args.bed.exists():
            shutil.copy(args.bed, root / "bed.restart")
        else:
            make = json.loads((root / "make.json").read_text())
            next(c for c in make if c["command"] == "run")["steps"] = args.settle
            (root / "make.json").write_text(json.dumps(make))
            command = [sys.executable, "-m", "engine", "-in", "make.json", "-log", "make.log", "-threads", "1"]
            for name, value in {"N": args.n, "SEED": 1, "HALF_WIDTH": half_width, "HEIGHT": 0.2}.items():
                command += ["-var", name, str(value)]
            env = {**os.environ, "PYTHONPATH": str(engines["new"]), "NUMBA_NUM_THREADS": "1"}
            subprocess.run(command, cwd=root, env=env, check=True, capture_output=True)
            if args.bed:
                shutil.copy(root / "bed.restart", args.bed)
        times = {side: {"pair": [], "neigh": []} for side in engines}
        digests = {}
        for rep in range(args.repeat + 1):  # repetition 0 compiles (or loads) the kernels: not counted
            for side in ("base", "new"):
                folder = root / f"{side}{rep}"
                folder.mkdir()
                for name in ("measure.json", "bed.restart"):
                    shutil.copy(root / name, folder / name)
                t = probe(engines[side], folder, args.calls if rep else 2, args.threads)
                digests[side] = t["digest"]
                if rep == 0:
                    continue
                for phase in ("pair", "neigh"):
                    times[side][phase].append(t[phase])
                print(f"{side:4} ({args.base if side == 'base' else args.new}): pair pass {t['pair'] * 1e9:6.1f} ns "
                      f"per particle ({t['pairs']:.2f} listed pairs each), neighbor rebuild "
                      f"{t['neigh'] * 1e9:6.1f} ns per particle (CPU, {args.threads} thread(s))", flush=True)
        for phase in ("pair", "neigh"):
            ratio = statistics.median(times["new"][phase]) / statistics.median(times["base"][phase])
            print(f"{phase}: CPU new / base {ratio:.3f} (median of {args.repeat})")
        print(f"same forces: {digests['base'] == digests['new']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
