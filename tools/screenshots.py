"""Screenshots of the built documentation site, for looking at it as a reader would.

Run from the repository root after ``mkdocs build --strict``:
``python tools/screenshots.py [chromium]``. It serves ``site/`` over HTTP (the
theme's search and navigation need a server, not file:// URLs) and writes PNGs of
the home page, a guide, an API page and a generated block of the performance page to
``docs/screenshots/`` with a headless Chromium (Debian's ``chromium`` by default).
"""

from __future__ import annotations

import contextlib
import http.server
import pathlib
import subprocess
import sys
import threading

ROOT = pathlib.Path(__file__).resolve().parent.parent
SITE = ROOT / "site"
OUT = ROOT / "docs" / "screenshots"
# page of the site -> screenshot; one of each kind of page.
PAGES = {
    "": "home.png",
    "guides/search/": "guide-search.png",
    "api/types/": "api-types.png",
    # The performance page down to its first generated block: a record's caption, tables and
    # figure (a long window: headless Chromium came out blank when sent to an anchor).
    "performance/": "performance.png",
}
TALL = {"performance/": "1440,3400"}
# A desktop window: the width at which the pages' 100-column code fits beside both sidebars.
WINDOW = "1440,900"


@contextlib.contextmanager
def serve(directory: pathlib.Path):
    """An HTTP server of ``directory`` on a free local port, in a thread; yields its URL."""

    def handler(*args, **kwargs):
        return http.server.SimpleHTTPRequestHandler(*args, directory=str(directory), **kwargs)

    class Quiet(http.server.ThreadingHTTPServer):
        def handle_error(self, request, client_address):
            pass  # Chromium drops connections it no longer needs; that is not an error

    http.server.SimpleHTTPRequestHandler.log_message = lambda *args: None
    server = Quiet(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()


def main(chromium: str = "chromium") -> None:
    if not (SITE / "index.html").exists():
        sys.exit("no site/: run `mkdocs build --strict` first")
    OUT.mkdir(parents=True, exist_ok=True)
    with serve(SITE) as url:
        for page, name in PAGES.items():
            png = OUT / name
            # --no-sandbox: Chromium refuses to start its sandbox as root (containers, CI).
            subprocess.run(
                [
                    chromium,
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--hide-scrollbars",
                    # Time for the figures to load and the page to scroll to an anchor before
                    # the picture is taken (without it the performance page came out blank).
                    "--virtual-time-budget=10000",
                    f"--window-size={TALL.get(page, WINDOW)}",
                    f"--screenshot={png}",
                    url + page,
                ],
                check=True,
                capture_output=True,
                timeout=120,
            )
            print(f"{png.relative_to(ROOT)}: {png.stat().st_size // 1024} KiB")


if __name__ == "__main__":
    main(*sys.argv[1:])
