"""The benchmarks: standalone scripts, run from the repository root as
``python benchmarks/<name>.py`` (each puts the root on ``sys.path`` so that
``benchmarks.*`` and ``tests.oracle`` import), and ``results.py`` that runs
them and assembles ``RESULTS.md``. Not part of the installed package.

The suites ``paper_tests``, ``peers``, ``swept_peers`` and ``time_vs_error``
each have ``run(quick, out)`` (returns its markdown section, writes CSV and
PNG files into ``out``) and ``main(argv)``. Their shared code is in
``harness`` (rows, timing, the check against a reference, figure style, and
``internals``, the one module importing jaxcontact's private names) and the
peers' code in ``peer_codes``. Optional packages (matplotlib, tqdm, scipy,
shapely, jax-md, libigl, numba, ipctk: the ``bench``, ``peers`` and
``peers2`` extras) are imported where used; a missing one is reported, never
a crash.
"""
