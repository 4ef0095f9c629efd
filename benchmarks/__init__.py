"""The benchmarks: ten maintained suites, each a script run from the repository root as
``python benchmarks/<suite>.py`` (each puts the root on ``sys.path`` so that ``benchmarks.*`` and
``tests.support.oracle`` import), and ``report.py``, which regenerates the report from their
records.
Not part of the installed package.

Every suite has ``run(args)`` (measures; returns its tables and figure data) and
``draw(record, pyplot)`` (its figure, from the stored record alone), and its command line is
``harness._run.suite``. Their shared code is in ``harness`` (the record format ``report``,
rows, timing, the check against a reference, figure style, and ``internals``, the one module
importing jaxcontact's private names) and the peers' code in ``peer_codes``. Optional packages
(matplotlib, tqdm, scipy, shapely, jax-md, libigl, numba, ipctk: the ``bench``, ``peers`` and
``peers2`` extras) are imported where used; a missing one is reported, never a crash.
The one-off experiments of earlier rounds are kept in commit ``5928bf7f76cc``
(``benchmarks/archive/``), not in the tree.
"""
