"""Stage 5, the driver of a run: ``build`` the stages, step them (``runner``), guard them
(``monitor``), write ``output``, ``fields`` and checkpoints (``state``), and
compare with a ``reference`` (modal), a ``monolithic`` run or the ``barwave``.
"""
