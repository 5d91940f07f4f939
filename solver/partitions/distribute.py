"""A partition's nodes distributed over its ranks: one *piece* per rank.

The partition's owned nodes are put in reverse Cuthill-McKee order (PETSc's
``rcm`` ordering of the node graph: small bandwidth, so MatMult reads its
vector nearly in order) and cut into contiguous chunks of equal size, one per
rank: for bars and chains the chunks are slabs with small interfaces.  Each
external node (a copy of another partition's node) is held by the piece that
holds a neighbour of it in the layer before (the lowest such piece).

A piece is a :class:`~solver.model.layout.Layout` whose ``owned`` are its chunk
(in RCM order) and whose layers are its external nodes, so local vectors are
``[owned | external]`` on every rank.  The partition's distributed numbering
puts piece 0's held nodes first, then piece 1's, and so on; ghosts *within*
the partition (rows that need another piece's nodes) are PETSc's business
(parallel AIJ), refreshed at every MatMult.

Rank 0 plans every partition's distribution with the whole model; each rank
then receives only its *slice* (:meth:`Distribution.slice_for`): its own
piece, the numbering of the nodes its share of the model touches (a
:class:`Numbering`, not an array over every node) and the partition's
external nodes (what the exchange fills, interface-sized), so no rank holds
the plan of every node.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.model.layout import Layout
from solver.petscutil import init


@dataclass(frozen=True)
class Piece(Layout):
    piece: int = 0                # rank within the partition
    pieces: int = 1               # ranks of the partition
    start: int = 0                # first held node in the partition's distributed numbering


class Numbering:
    """A partition's distributed numbering of some nodes: ``numbering[nodes]``
    is each node's distributed index, -1 where not held (or not known here),
    as from an array over every node.  ``nodes`` sorted, ``numbers`` theirs
    (all >= 0)."""

    def __init__(self, nodes: np.ndarray, numbers: np.ndarray):
        self.nodes, self.numbers = nodes, numbers

    def __getitem__(self, nodes) -> np.ndarray:
        nodes = np.asarray(nodes, dtype=np.int64)
        if not self.nodes.size:
            return np.full(nodes.shape, -1, dtype=np.int64)
        pos = np.minimum(np.searchsorted(self.nodes, nodes), self.nodes.size - 1)
        return np.where(self.nodes[pos] == nodes, self.numbers[pos], -1)


@dataclass(frozen=True)
class Distribution:
    """The pieces of one partition and its distributed node numbering.  Rank
    0's plan holds the whole partition (``layout``), every piece and an
    array over every node; a rank's slice (:meth:`slice_for`) has no
    ``layout``, its own piece only (``None`` for the others) and the
    numbering of the nodes near it."""

    layout: Layout | None         # the whole partition (None in a slice)
    pieces: tuple                 # every piece (Piece; None for another rank's in a slice)
    number: object                # node -> distributed index, -1 elsewhere (array or Numbering)
    n_held: int                   # held nodes of the whole partition
    external: np.ndarray          # the whole partition's external nodes (what exchanges fill)
    n_layers: int                 # external layers
    dof_starts: tuple | None = None   # a slice's: every piece's first DOF, then the total

    @classmethod
    def of(cls, layout: Layout, pieces, number) -> "Distribution":
        return cls(layout, tuple(pieces), number, layout.n_held, layout.external,
                   len(layout.layers))

    def held(self) -> np.ndarray:
        """The whole partition's held nodes (a slice: those near its piece,
        all that its share of the model can ask about)."""
        if self.layout is not None:
            return self.layout.held
        if isinstance(self.number, Numbering):
            return self.number.nodes
        return np.flatnonzero(self.number >= 0)

    def dofs(self, piece: int, dofmap) -> tuple[int, int]:
        """(first DOF of ``piece`` in the partition's distributed DOF numbering,
        the partition's DOFs)."""
        starts = self.dof_starts or self.piece_dofs(dofmap)
        return int(starts[piece]), int(starts[-1])

    def piece_dofs(self, dofmap) -> tuple:
        """Every piece's first DOF in the distributed DOF numbering, then the
        partition's DOFs (the whole plan's pieces)."""
        return tuple(np.concatenate([[0], np.cumsum([dofmap.count(pc.held)
                                                     for pc in self.pieces])]).tolist())

    def slice_for(self, piece, near, dofmap, dof_starts=None) -> "Distribution":
        """What the rank of ``piece`` (None: a rank without one) needs: its
        piece and the numbering of ``near`` (sorted: the nodes its share of
        the model touches, its held nodes and their neighbours).  Nodes with
        differing DOF counts keep the array over every node (their scalar
        matrix numbers DOFs through every node before its own).
        ``dof_starts``: :meth:`piece_dofs`, if made already (every rank's
        slice has the same)."""
        pieces = [None] * len(self.pieces)
        number = Numbering(np.zeros(0, np.int64), np.zeros(0, np.int64))
        if piece is not None:
            pieces[piece] = self.pieces[piece]
            if dofmap.block is None:
                number = self.number
            else:
                at = self.number[near]
                number = Numbering(near[at >= 0], at[at >= 0])
        return Distribution(None, tuple(pieces), number, self.n_held, self.external,
                            self.n_layers, dof_starts or self.piece_dofs(dofmap))


def whole(layout: Layout, n_nodes: int) -> Distribution:
    """``layout`` as one piece in its own node order (a partition not split over
    ranks, e.g. the GC subdomains)."""
    piece = Piece(layout.name, layout.index, layout.owned, layout.boundary, layout.interior,
                  layout.layers, layout.external_owner)
    number = np.full(n_nodes, -1, dtype=np.int64)
    number[piece.held] = np.arange(piece.n_held)
    return Distribution.of(layout, (piece,), number)


def rcm(nodes: np.ndarray, graph) -> np.ndarray:
    """``nodes`` in reverse Cuthill-McKee order of the subgraph they induce
    (PETSc's ``rcm`` on a SeqAIJ made on the subgraph's CSR arrays, no copy;
    its values are never read, so their zero pages are never touched)."""
    n = nodes.size
    if n <= 2:
        return nodes.copy()
    P = init()
    srt = np.sort(np.asarray(nodes, dtype=np.int64))
    indptr, indices = graph.induced(srt)         # sorted nodes: sorted columns
    G = P.Mat().createAIJWithArrays((n, n), (indptr.astype(P.IntType), indices.astype(
        P.IntType, copy=False), np.zeros(indices.size, dtype=P.ScalarType)), comm=P.COMM_SELF)
    perm, _ = G.getOrdering("rcm")
    out = perm.getIndices().copy()
    perm.destroy()
    G.destroy()
    return srt[out]


def split(layout: Layout, graph, k: int, order=True) -> Distribution:
    """Distribute ``layout`` over ``k`` ranks (k = 1: one piece, RCM order) by
    the node ``graph``."""
    owned = rcm(layout.owned, graph) if order else layout.owned
    n = owned.size
    sizes = [n // k + (1 if r < n % k else 0) for r in range(k)]
    cuts = np.concatenate([[0], np.cumsum(sizes)])
    n_nodes = graph.n_nodes
    piece_of = np.full(n_nodes, -1, dtype=np.int64)
    piece_of[owned] = np.repeat(np.arange(k), sizes)
    ext_piece = []
    for layer in layout.layers:
        # the lowest piece among a node's neighbours already placed (owned or earlier layers)
        placed = np.zeros(layer.size, dtype=np.int64)
        for i, g in enumerate(layer.tolist()):
            prev = piece_of[graph.row(g)]
            prev = prev[prev >= 0]
            placed[i] = prev.min() if prev.size else 0
        piece_of[layer] = placed             # a layer's nodes place the next layer's
        ext_piece.append(placed)
    owner_of = np.full(n_nodes, -1, dtype=np.int64)
    owner_of[layout.external] = layout.external_owner
    is_boundary = np.zeros(n_nodes, bool)
    is_boundary[layout.boundary] = True
    pieces, start = [], 0
    number = np.full(n_nodes, -1, dtype=np.int64)
    for r in range(k):
        own = owned[cuts[r]:cuts[r + 1]]
        layers = tuple(np.sort(layer[where == r]) for layer, where in zip(layout.layers, ext_piece))
        layers = tuple(l for l in layers if l.size) if k > 1 else layers
        ext = np.concatenate(layers) if layers else np.zeros(0, dtype=np.int64)
        is_b = is_boundary[own]
        piece = Piece(layout.name, layout.index, own, own[is_b], own[~is_b], layers,
                      owner_of[ext], piece=r, pieces=k, start=start)
        number[piece.held] = start + np.arange(piece.n_held)
        start += piece.n_held
        pieces.append(piece)
    return Distribution.of(layout, pieces, number)


def piece_on(dists, assignment, p: int, rank: int) -> Piece:
    """Partition ``p``'s piece on world ``rank`` (``assignment``: a
    :class:`~solver.partitions.ranks.Assignment`, ``dists`` its distributions)."""
    return dists[p].pieces[assignment.ranks[p].index(rank)]


def held_on(dists, assignment, rank: int) -> np.ndarray:
    """The nodes every piece on world ``rank`` holds, concatenated (what its
    share of the model must touch)."""
    held = [piece_on(dists, assignment, p, rank).held for p in assignment.partitions_on(rank)]
    return np.concatenate(held) if held else np.zeros(0, np.int64)
