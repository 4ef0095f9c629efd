"""Entry point of ``jaxcontact.bench.swept_peers`` (the same code ``jaxcontact bench`` runs).

python benchmarks/swept_peers.py [--quick] [--out DIR]
"""

import sys

from jaxcontact.bench.swept_peers import main

if __name__ == "__main__":
    sys.exit(main())
