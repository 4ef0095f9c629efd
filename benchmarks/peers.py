"""Entry point of ``jaxcontact.bench.peers`` (the same code ``jaxcontact bench`` runs).

python benchmarks/peers.py [--quick] [--out DIR]
"""

import sys

from jaxcontact.bench.peers import main

if __name__ == "__main__":
    sys.exit(main())
