"""Entry point of ``jaxcontact.bench.paper_tests`` (the same code ``jaxcontact bench`` runs).

python benchmarks/paper_tests.py [--quick] [--out DIR]
"""

import sys

from jaxcontact.bench.paper_tests import main

if __name__ == "__main__":
    sys.exit(main())
