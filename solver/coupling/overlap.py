"""The old import path of :mod:`solver.model.layout` (partition layouts), kept for the tests
and benchmarks that import it."""
from solver.model.layout import Layout, derive, layer_counts, owner_map

__all__ = ["Layout", "derive", "layer_counts", "owner_map"]
