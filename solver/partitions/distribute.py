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


@dataclass(frozen=True)
class Distribution:
    """The pieces of one partition and its distributed node numbering."""

    layout: Layout                # the whole partition
    pieces: tuple[Piece, ...]
    number: np.ndarray            # [n_nodes] distributed index of every held node, -1 elsewhere

    @property
    def n_held(self) -> int:
        return self.layout.n_held


def whole(layout: Layout, n_nodes: int) -> Distribution:
    """``layout`` as one piece in its own node order (a partition not split over
    ranks, e.g. the GC subdomains)."""
    piece = Piece(layout.name, layout.index, layout.owned, layout.boundary, layout.interior,
                  layout.layers, layout.external_owner)
    number = np.full(n_nodes, -1, dtype=np.int64)
    number[piece.held] = np.arange(piece.n_held)
    return Distribution(layout, (piece,), number)


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
    return Distribution(layout, tuple(pieces), number)


def piece_on(dists, assignment, p: int, rank: int) -> Piece:
    """Partition ``p``'s piece on world ``rank`` (``assignment``: a
    :class:`~solver.partitions.ranks.Assignment`, ``dists`` its distributions)."""
    return dists[p].pieces[assignment.ranks[p].index(rank)]


def held_on(dists, assignment, rank: int) -> np.ndarray:
    """The nodes every piece on world ``rank`` holds, concatenated (what its
    share of the model must touch)."""
    held = [piece_on(dists, assignment, p, rank).held for p in assignment.partitions_on(rank)]
    return np.concatenate(held) if held else np.zeros(0, np.int64)
