"""What the benchmark scripts share: rows and tables (``run``), timing, the check of an
answer against a reference (``check``), figure style, and the library's internals the
benchmarks time (``internals``, the only module that imports them)."""
