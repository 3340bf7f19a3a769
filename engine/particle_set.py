"""Particles in and out of a running simulation: the only place that changes the particle set mid-run.

At a stop of the run loop (`engine.runner`) the forces of the current positions were just evaluated by the
compiled kernel, and the next chunk of steps starts with the first half kick and drift (kernels.py
`drift_pass`), then rebuilds the neighbor list when a particle moved more than skin/2 since its `x_build`.
Setting `sim.dirty` there would make the next run evaluate the forces again (`kernel.setup`) and advance the
tangential history of every contact a second time; instead `insert` and `remove` change the particle state
AND the neighbor list together so that the list stays valid for the next step and every surviving pair keeps
its contact history:

- `insert` appends rows to every particle array (order of the others unchanged) and gives the new particles
  empty rows in the half list (`start`) and in the partner index (`rstart`). Their `x_build` is `FAR`, so the
  next step's drift pass counts them as moved beyond skin/2 (d2 = |x - FAR|^2 ~ 3e300, finite, above any
  (skin/2)^2; kernels.py DRIFT: `if d2 > half_skin_sq: need += 1`) and rebuilds the list before the first
  force evaluation that sees them; the rebuild carries every existing pair's history over as at any rebuild.
  A finite marker rather than +inf: a restart file written at this stop must pass the restart check (every
  float finite).
- `remove` drops rows (the survivors keep their order), keeps the pairs of two survivors with their history
  and reaction rows, remaps the partner indices and recomputes the partner index (`neighbor.reverse_index`).
  The survivors' `x_build` is unchanged: the list of the survivors is still complete (a removed particle can
  only take pairs away), so no rebuild is needed and the bytes of the survivors' trajectories are those of a
  run in which the removed particles never were (when they exerted no force).

Before the first run (or after particles were created by a command: `sim.dirty`) the list is not yet built;
then only the state changes and the run's set-up builds the list.
"""
from __future__ import annotations

import numpy as np

from . import state as particle_state
from .neighbor import reverse_index, stale_band

#: x_build of an inserted particle: beyond any domain, so that the next drift pass finds it "moved" by more
#: than skin/2 and rebuilds; finite (its square, ~1e300 per axis, too) so that restart files stay checkable
FAR = 1e150


def _list_is_current(sim, n: int) -> bool:
    """The neighbor list belongs to these n particles (built by a run and not stale)."""
    return not sim.dirty and len(sim.nbr.start) == n + 1


def insert(sim, **arrays):
    """Append particles (arrays per state field, one row each; missing fields are zero, `x_build` is FAR)
    mid-run, keeping the neighbor list and every contact's history. Ids are the caller's (`pid`)."""
    n_old = sim.n
    count = len(arrays["x"])
    if count == 0:
        return
    arrays.setdefault("x_build", np.full((count, 3), FAR))
    current = _list_is_current(sim, n_old)
    sim.state = particle_state.append(sim.state, **arrays)
    if current:
        nbr = sim.nbr
        sim.nbr = nbr._replace(start=np.concatenate([nbr.start, np.full(count, nbr.start[-1], dtype=np.int64)]),
                               rstart=np.concatenate([nbr.rstart, np.full(count, nbr.rstart[-1],
                                                                            dtype=np.int64)]),
                               own=np.concatenate([nbr.own, np.zeros(count, dtype=np.uint8)]),
                               **stale_band(n_old + count))
    mesh = sim.mesh_nbr
    if len(mesh.start) == n_old + 1:  # the new particles touch no triangle until the rebuild lists theirs
        sim.mesh_nbr = mesh._replace(start=np.concatenate([mesh.start, np.full(count, mesh.start[-1],
                                                                                dtype=np.int64)]),
                                     owner=np.concatenate([mesh.owner, sim.state.pid[n_old:]]))


def remove(sim, keep_mask) -> int:
    """Remove the particles where keep_mask is False, mid-run; the others keep their order, their pairs and
    the pairs' history. Returns the number removed."""
    keep = np.asarray(keep_mask, dtype=bool)
    n_old = sim.n
    if keep.shape != (n_old,):
        raise ValueError(f"keep mask of shape {keep.shape} for {n_old} particles")
    removed = int(n_old - np.count_nonzero(keep))
    if removed == 0:
        return 0
    current = _list_is_current(sim, n_old)
    sim.state = particle_state.take(sim.state, np.nonzero(keep)[0])
    if current:
        sim.nbr = _compact_list(sim.nbr, keep)
    if len(sim.mesh_nbr.start) == n_old + 1:
        sim.mesh_nbr = _compact_mesh_list(sim.mesh_nbr, keep)
    return removed


def _compact_mesh_list(mesh, keep: np.ndarray):
    """The particle-triangle list (engine/mesh.py) of the survivors: their rows in order, with history."""
    counts = np.diff(mesh.start)
    entry_kept = np.repeat(keep, counts)
    start = np.zeros(int(np.count_nonzero(keep)) + 1, dtype=np.int64)
    np.cumsum(counts[keep], out=start[1:])
    return mesh._replace(start=start, tri=mesh.tri[entry_kept], hist=np.ascontiguousarray(mesh.hist[entry_kept]),
                         touch=mesh.touch[entry_kept], owner=mesh.owner[keep])


def _compact_list(nbr, keep: np.ndarray):
    """The half list of the survivors: pairs of two survivors in their order, indices remapped, history and
    reaction rows kept, partner index recomputed."""
    n_old = len(keep)
    new_index = np.cumsum(keep) - 1  # survivor's new row; meaningless for removed ones (never read)
    owner = np.repeat(np.arange(n_old), np.diff(nbr.start))
    pair_kept = keep[owner] & keep[nbr.j]
    new_j = new_index[nbr.j[pair_kept]].astype(np.int32)
    per_owner = np.bincount(owner[pair_kept], minlength=n_old)[keep]
    new_start = np.zeros(len(per_owner) + 1, dtype=np.int64)
    np.cumsum(per_owner, out=new_start[1:])
    # history: one row per pair, or none at all (no submodel stores history)
    hist = nbr.hist[pair_kept] if nbr.hist.shape[0] == len(nbr.j) else nbr.hist
    rstart, rslot = reverse_index(new_start, new_j, len(per_owner))
    reaction = np.zeros((len(new_j), nbr.reaction.shape[1]))
    touch = np.zeros(len(new_j), dtype=np.uint8)
    if nbr.reaction.shape[0] == len(nbr.j):
        reaction[rslot] = nbr.reaction[nbr.rslot[pair_kept]]
        touch[rslot] = nbr.touch[nbr.rslot[pair_kept]]
    # live bytes (engine/neighbor.py) follow their pairs; a list without them tests every history (1)
    live = nbr.live[pair_kept] if nbr.live.shape == nbr.j.shape else np.ones(len(new_j), dtype=np.uint8)
    return nbr._replace(start=new_start, j=new_j, hist=np.ascontiguousarray(hist), rstart=rstart, rslot=rslot,
                        reaction=reaction, touch=touch, own=nbr.own[keep], live=live, **stale_band(len(per_owner)))
