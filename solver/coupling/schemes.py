"""The built-in coupling schemes (``coupling.scheme``): importing this module
defines, and so registers (:mod:`solver.scene.registry`), every one of them.

Each scheme is one :class:`~solver.coupling.scheme.Scheme` subclass that
declares its facts and rules; the listing order (``python -m solver
schemes``, docs/scene.md) is the order of the imports below.  The tables
here are views of the registry for their callers (the sweep tool, tests).
"""
from __future__ import annotations

from solver.coupling import system_step, gc, conserving, transition_zone  # noqa: F401 (register)
from solver.scene import registry


def scheme_class(name: str):
    """The class of scheme ``name``."""
    return registry.lookup(name)


def _view(fact: str) -> dict:
    return {name: getattr(cls, fact) for name, cls in registry.declared().items()}


# what each scheme is, accepts and allows, for users (``python -m solver schemes``)
ABOUT = _view("about")
SUPPORT = _view("supports")
LIMIT = _view("limit")
# schemes whose partitions take coupling.external, and the most ranks a scheme runs on
USES_EXTERNAL = {name for name, cls in registry.declared().items() if cls.uses_external}
MAX_RANKS = {name: cls.max_ranks for name, cls in registry.declared().items()
             if cls.max_ranks is not None}
