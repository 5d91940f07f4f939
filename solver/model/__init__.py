"""Stage 2, the model: the scene's structure as arrays.

``data`` reads the network or the gmsh mesh once per run (a ``ModelData``),
``binding`` parses the scene and checks its keys against it and resolves groups;
``arrays`` (networks) and ``continuum`` (meshes, ``elements``, ``lattice``,
``cell_blocks``, ``boundary``) build the model the partitions take their share of;
``generators`` and ``loads`` are their inputs, ``layout`` the partitions' node sets.
"""
