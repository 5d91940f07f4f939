"""Stage 5, the driver of a run: ``build`` the stages, step them (``runner``, telling its
``observers``), guard them (``monitor``), write ``output``, ``fields``, the ``report``
and ``checkpoint``s (format: ``state``), and compare with a ``reference`` (modal), a ``monolithic`` run or the ``barwave``.
"""
