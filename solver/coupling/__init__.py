"""Stage 4, the coupling: what one system step does.

``overlap`` derives the boundary, interior and external layers, ``exchange``
refreshes external copies with one VecScatter, ``system_step`` holds the
overlap and staggered schemes, ``gc`` the Gravouil-Combescure scheme, and
``schemes`` is their one registry.
"""
