"""The contact halo of a dem partition split over ranks (``model.lattice.contact``).

A piece counts the contacts of its own (owned) particles; the other end may
be any particle of the partition that comes within 2r of one.  Besides the
particles it holds and its bond ghosts (the other pieces' ends of its bonds)
a piece therefore sees its *halo*: the other pieces' particles that were
within 2r + skin of one of its owned particles when the k-d trees were last
built.  Until the next build no particle moves more than skin / 2 (that is
when the trees are rebuilt), so every particle that comes within 2r of an
owned one was within 2r + skin of it at the build and is in the halo: the
halo covers the contact search by construction, whatever the radius and skin.

The trees are rebuilt on all pieces at once, when any piece's is stale (one
small allreduce per force evaluation), since the ghost scatter that
refreshes the halo is created again, collectively, with the new halo.  At a
build every piece

1. allgathers the bounding box of its owned contact particles' positions;
2. sends every other piece whose box, grown by 2r + skin, contains some of
   the contact particles it holds their global ids, partition numbers, rest
   positions, masses and current positions (one alltoallv; nothing else of
   the model is needed to place them);
3. keeps of what it receives the particles within 2r + skin of one of its
   owned particles (a k-d tree query) that are not already bond ghosts.

Each piece exchanges with the pieces near it and only its halo travels, once
per force evaluation through the ghost scatter: no piece gathers every
particle of the partition.
"""
from __future__ import annotations

import numpy as np

# a particle on the boundary of the reach is kept: a margin for the rounding
# of the distances, which the trees compute in their own order
MARGIN = 1e-9


class ContactHalo:
    """The halo exchange of one piece of a dem partition.

    ``comm``: the partition's communicator (mpi4py); ``reach``: 2r + skin;
    ``owned``: local indices of the piece's owned contact particles;
    ``provided``: local indices of the contact particles it holds (owned and
    external), which it offers the other pieces, with their global ids
    ``ids``, partition numbers ``number``, rest positions ``rest`` [n, dim]
    and masses ``mass``; ``known``: global ids the piece has already (the
    particles it holds and its bond ghosts): never taken twice.  An
    external particle (another partition's, copied by the exchange) may be
    held by several pieces and so arrive from several: it is kept once."""

    def __init__(self, comm, reach, owned, provided, ids, number, rest, mass, known):
        self.comm = comm
        self.reach = float(reach)
        self.owned = np.asarray(owned, dtype=np.int64)
        self.provided = np.asarray(provided, dtype=np.int64)
        dim = rest.shape[1]
        self.dim = dim
        # one row per offered particle: id, number, X, mass, then the current x
        self._rows = np.zeros((self.provided.size, 3 + 2 * dim))
        self._rows[:, 0], self._rows[:, 1] = ids, number
        self._rows[:, 2:2 + dim], self._rows[:, 2 + dim] = rest, mass
        self.known = np.sort(np.asarray(known, dtype=np.int64))
        self._flag = np.zeros(1, np.int64), np.zeros(1, np.int64)
        self.sizes = []                  # the halo's size at each build (this piece)

    def stale(self, mine: bool) -> bool:
        """Collective: whether any piece's tree is stale (``mine``: this piece's)."""
        send, got = self._flag
        send[0] = int(mine)
        self.comm.Allreduce(send, got)
        return bool(got[0])

    def select(self, x):
        """Collective: the new halo at local positions ``x`` (its first rows:
        the held particles'), as (global ids, partition numbers, rest
        positions, masses), by global id."""
        comm, dim, grow = self.comm, self.dim, self.reach * (1 + MARGIN)
        mine = x[self.owned]
        box = np.concatenate([mine.min(axis=0, initial=np.inf),
                              mine.max(axis=0, initial=-np.inf)])
        boxes = np.zeros((comm.size, 2 * dim))
        comm.Allgather(box, boxes)
        rows = self._rows
        rows[:, 3 + dim:] = x[self.provided]
        at = rows[:, 3 + dim:]
        send, counts = [], np.zeros(comm.size, np.int64)
        for r in range(comm.size):
            if r == comm.rank:
                continue
            lo, hi = boxes[r, :dim] - grow, boxes[r, dim:] + grow
            near = np.flatnonzero(np.all((at >= lo) & (at <= hi), axis=1))
            send.append(rows[near])
            counts[r] = near.size * rows.shape[1]
        got = np.zeros(comm.size, np.int64)
        comm.Alltoall(counts, got)
        out = np.concatenate(send) if send else np.zeros((0, rows.shape[1]))
        back = np.zeros((int(got.sum()) // rows.shape[1], rows.shape[1]))
        comm.Alltoallv([out, (counts.tolist(), _starts(counts))],
                       [back, (got.tolist(), _starts(got))])
        back = self._trimmed(back, mine, grow)
        self.sizes.append(len(back))
        ids = back[:, 0].astype(np.int64)
        return (ids, back[:, 1].astype(np.int64), back[:, 2:2 + dim].copy(),
                back[:, 2 + dim].copy())

    def _trimmed(self, rows, mine, grow):
        """The received ``rows`` within ``grow`` of an owned position
        ``mine`` and not known already, by global id."""
        if not len(rows) or not len(mine):
            return rows[:0]
        from scipy.spatial import cKDTree  # lazy: scipy loads only where it is used
        dist, _ = cKDTree(mine).query(rows[:, 3 + self.dim:], distance_upper_bound=grow)
        ids = rows[:, 0].astype(np.int64)
        keep = np.isfinite(dist) & ~np.isin(ids, self.known)
        rows, ids = rows[keep], ids[keep]
        _, first = np.unique(ids, return_index=True)   # by id, each once
        return rows[first]


def _starts(counts) -> list:
    """Displacements of consecutive blocks of ``counts``."""
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64).tolist()
