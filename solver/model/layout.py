"""Partition layouts: owned, boundary, interior and external nodes.

Derived from the connectivity, never typed by the user.  A partition's
*boundary* (B) is the set of its nodes adjacent to another partition; its
*external* nodes (E) are copies of other partitions' nodes, in layers: layer 1
is adjacent to the owned set, layer l+1 adjacent to layer l.  The *held* nodes
are owned followed by the external layers; this is the order of every local
vector, so owned values are the leading slice and external values the tail.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Layout:
    """Node sets of one partition (global node ids, sorted within each set)."""

    name: str
    index: int
    owned: np.ndarray
    boundary: np.ndarray
    interior: np.ndarray
    layers: tuple[np.ndarray, ...]
    external_owner: np.ndarray      # [n_external] owning partition of each external node

    @property
    def external(self) -> np.ndarray:
        return np.concatenate(self.layers) if self.layers else np.zeros(0, dtype=np.int64)

    @property
    def held(self) -> np.ndarray:
        return np.concatenate([self.owned, self.external])

    @property
    def n_owned(self) -> int:
        return self.owned.size

    @property
    def n_held(self) -> int:
        return self.owned.size + sum(l.size for l in self.layers)

    def local(self, nodes) -> np.ndarray:
        """Local (held) indices of global ``nodes``; -1 where not held."""
        held = self.held
        order = np.argsort(held)
        pos = np.searchsorted(held[order], nodes)
        pos = np.minimum(pos, held.size - 1)
        hit = held[order][pos] == nodes
        return np.where(hit, order[pos], -1)


def owner_map(n_nodes: int, partitions) -> np.ndarray:
    """Owning partition index of every node."""
    owner = np.full(n_nodes, -1, dtype=np.int64)
    for p, part in enumerate(partitions):
        owner[np.asarray(part.nodes, dtype=np.int64)] = p
    return owner


def derive(graph, partitions, n_layers) -> list[Layout]:
    """Layouts of all partitions.

    graph: the node graph (:class:`solver.model.graph.Graph`); partitions:
    objects with ``name`` and ``nodes``; n_layers: number of external layers of
    each partition.  The neighbour lists are read ``CHUNK`` nodes at a time:
    no array as long as the graph's edges is made (a row index and an owner
    per edge were 300 MB of rank 0's planning peak on the 2.27 M-DOF bar).
    """
    n = graph.n_nodes
    owner = owner_map(n, partitions)
    layouts = []
    for p, part in enumerate(partitions):
        owned = np.unique(np.asarray(part.nodes, dtype=np.int64))
        is_b = graph.neighbour_sums(owned, owner != p, CHUNK) > 0
        seen = np.zeros(n, bool)
        seen[owned] = True
        front, layers = owned, []
        for _ in range(n_layers[p]):
            reach = np.zeros(n, bool)
            for s in range(0, front.size, CHUNK):
                reach[graph.rows(front[s:s + CHUNK])] = True
            layer = np.flatnonzero(reach & ~seen)
            if not layer.size:
                break
            layers.append(layer)
            seen[layer] = True
            front = layer
        ext = np.concatenate(layers) if layers else np.zeros(0, dtype=np.int64)
        layouts.append(Layout(part.name, p, owned, owned[is_b], owned[~is_b], tuple(layers),
                              owner[ext]))
    return layouts


CHUNK = 65536                   # nodes whose neighbour lists derive reads at a time


def layer_counts(partitions, treatments) -> list[int]:
    """External layers per partition: one, or one per sub-step (``layers``)."""
    big = max(p.ratio for p in partitions)
    return [big // p.ratio if t == "layers" else 1 for p, t in zip(partitions, treatments)]
