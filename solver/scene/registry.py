"""The registry of coupling schemes (``coupling.scheme``): name -> scheme class.

Every scheme is one class, a subclass of :class:`solver.coupling.scheme.Scheme`,
that declares its facts (``about``, ``supports``, ``limit``, ...) and its rules
(``validate(scene)``, ``check_launch``, its stability rule) and registers here
when it is defined (``Scheme.__init_subclass__``), as SfePy's solvers do.  The
scene validates ``coupling.scheme`` against :func:`names`, ``python -m solver
schemes`` and the scheme table of docs/scene.md list :func:`declared`, and
the lower stages ask :func:`lookup` for a scheme's rules instead of testing
its name.

The registry sits at the scene's stage (1) so that every stage can use it; the
classes are at the coupling stage (4).  No module of the scene imports the
coupling: the built-in schemes are defined by the modules that ``PROVIDER``
imports, and this module loads ``PROVIDER`` by name the first time a scheme is
asked for (as a plugin's entry point is loaded), not when the scene is imported.
"""
from __future__ import annotations

import importlib

PROVIDER = "solver.coupling.schemes"     # imports every built-in scheme's module

_schemes: dict[str, type] = {}           # name -> class, in registration order
_loaded = False


def register(cls) -> type:
    """Add scheme class ``cls`` under ``cls.name`` (a second class of the same name is refused)."""
    known = _schemes.get(cls.name)
    if known is not None and known is not cls:
        raise TypeError(f"coupling scheme {cls.name!r} is already registered ({known.__qualname__})")
    _schemes[cls.name] = cls
    return cls


def unregister(name: str) -> None:
    """Remove scheme ``name`` (tests register toy schemes and take them out again)."""
    _schemes.pop(name, None)


def _load() -> None:
    global _loaded
    if not _loaded:
        _loaded = True                   # PROVIDER's own import asks the registry too
        try:
            importlib.import_module(PROVIDER)
        except BaseException:
            _loaded = False
            raise


def declared() -> dict[str, type]:
    """Every registered scheme, name -> class, in registration order."""
    _load()
    return dict(_schemes)


def names() -> tuple[str, ...]:
    """The allowed values of ``coupling.scheme``."""
    return tuple(declared())


def lookup(name: str) -> type:
    """The class of scheme ``name`` (a KeyError for a name the scene did not validate)."""
    return declared()[name]
