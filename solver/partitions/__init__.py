"""Stage 3, the partitions: rank assignment, distribution, assembly, stepping.

``partitioning`` derives layouts, assigns ``ranks``, ``distribute``s each
partition over its ranks and checks ``stability``; ``fem`` and ``dem`` (on
``partition``) hold the operators ``assembly`` builds and step the
``integrators`` through a ``force``.
"""
