"""What the tests share and are not tests themselves: the exact oracle (``oracle``) and the
checks built on it (``exact_checks``), scenes and comparisons (``helpers``), the table of
tolerances (``tolerances``) and the compile-count plugin (``compile_log``). Kept apart from
the test files so that a module here is never collected and a test file is never imported."""
