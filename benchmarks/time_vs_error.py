"""Entry point of ``jaxcontact.bench.time_vs_error`` (the same code ``jaxcontact bench`` runs).

python benchmarks/time_vs_error.py [--quick] [--out DIR]
"""

import sys

from jaxcontact.bench.time_vs_error import main

if __name__ == "__main__":
    sys.exit(main())
