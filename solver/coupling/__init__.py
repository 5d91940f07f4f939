"""Stage 4, the coupling: what one system step does.

The partitions' layouts (boundary, interior and external layers) are the
model's (:mod:`solver.model.layout`; ``overlap`` is its old import path); ``exchange``
refreshes external copies with one VecScatter, ``system_step`` holds the
overlap and staggered schemes, ``gc`` the Gravouil-Combescure scheme, and
``schemes`` is their one registry.
"""
