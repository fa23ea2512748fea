"""What the cases of :mod:`granflow.cases` are made with and run by (issue 18 item 4; moved out of
``granflow.cases``, which holds case files only):

* :mod:`~granflow.casekit.registry` -- the :data:`CASES` registry and its :class:`Case` record;
* :mod:`~granflow.casekit.common`, :mod:`~granflow.casekit.preparation` -- shared set-up helpers
  (the model of a config, initial fields, bed preparation);
* :mod:`~granflow.casekit.options` -- the option listing of ``granflow run --help-case``;
* :mod:`~granflow.casekit.headlines` -- each case's end-of-run headline;
* :mod:`~granflow.casekit.runner` -- ``granflow run``: one case run with its writers and summary,
  with :mod:`~granflow.casekit.restart`, :mod:`~granflow.casekit.memory` and
  :mod:`~granflow.casekit.step_clock`;
* :mod:`~granflow.casekit.sweep_member` -- one member of a parameter sweep.

The old paths ``granflow.cases.<module>`` keep working (:func:`granflow.registry.alias_modules`).
Nothing is imported here, so ``import granflow.casekit.registry`` stays light.
"""
