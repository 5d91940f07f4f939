"""Stage 2, the model: the scene's structure as arrays.

``data`` reads the network or the gmsh mesh once, ``binding`` checks the
scene's keys against it and resolves groups; ``arrays`` (networks) and
``continuum`` (meshes, ``elements``, ``lattice``) build the model the
partitions take their share of; ``generators`` and ``loads`` are their inputs.
"""
