"""What the problems' demos share: writing a picture where matplotlib is installed."""

from __future__ import annotations

import os


def write_png(folder: str, name: str, draw) -> None:
    """``draw(path)`` into ``folder/name`` with matplotlib set to draw with no display,
    and says where; without matplotlib, says why the PNG is skipped."""
    try:
        import matplotlib
    except ImportError:
        print('PNG skipped: matplotlib is not installed (pip install "jaxcontact[bench]").')
        return
    matplotlib.use("Agg")  # headless: no display needed
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, name)
    draw(path)
    print(f"wrote {path}")
