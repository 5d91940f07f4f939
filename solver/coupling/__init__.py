"""Stage 4, the coupling: what one system step does.

The partitions' layouts (boundary, interior and external layers) are the
model's (:mod:`solver.model.layout`);
``exchange`` refreshes external copies with one VecScatter.  ``scheme``
declares the interface of a coupling scheme
(:class:`~solver.coupling.scheme.Scheme`: its facts and rules;
docs/dev/schemes.md); ``system_step`` holds the overlap and staggered schemes,
``gc`` the Gravouil-Combescure scheme, ``conserving`` the energy-conserving
one, ``transition_zone`` the transition-zone scheme, and ``schemes`` imports
them all (each registers itself in :mod:`solver.scene.registry`).
"""
