"""mkdocs hooks: the docs pages' links to repository files outside ``docs/``.

The pages are read on GitHub as well as on the site, so they link to the
repository's files (``../CHANGELOG.md``, ``../benchmarks/RESULTS.md``). The
site holds only ``docs/``: a link to a file it carries as a page of its own
(``REPOSITORY_PAGES``) is pointed at that page; a link to another file that
exists is written as its repository path in code, since the site cannot serve
it. A link to nothing is left alone, for ``mkdocs build --strict`` to fail on.

The benchmark figures are the exception: the performance page shows the PNGs the suites store
beside their JSON in ``benchmarks/results/`` (``benchmarks/report.py`` links them there), so
``on_files`` serves that folder's figures at the same path on the site, and an image link to
one is pointed at it.
"""

from __future__ import annotations

import os
import pathlib
import re

from mkdocs.structure.files import File

# Repository file -> the docs page that includes it.
REPOSITORY_PAGES = {"CHANGELOG.md": "changelog.md"}

# [text](target) and ![text](target); the target without spaces or a title.
LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")
FIGURES = "benchmarks/results"  # served on the site at this path


def on_files(files, config):
    root = pathlib.Path(config["docs_dir"]).resolve().parent
    for png in sorted((root / FIGURES).rglob("*.png")):
        path = png.relative_to(root).as_posix()
        files.append(File(path, str(root), config["site_dir"], config["use_directory_urls"]))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    docs = pathlib.Path(config["docs_dir"]).resolve()
    root = docs.parent
    source = (docs / page.file.src_path).parent

    def rewrite(match: re.Match) -> str:
        bang, text, target = match.groups()
        if re.match(r"^[a-z][a-z0-9+.-]*:|^#|^/", target):
            return match.group(0)  # a URL, an anchor on this page or an absolute path
        path, _, anchor = target.partition("#")
        resolved = (source / path).resolve()
        if resolved.is_relative_to(docs) or not resolved.exists():
            return match.group(0)
        name = resolved.relative_to(root).as_posix()
        if bang and name.startswith(FIGURES + "/"):
            served = os.path.relpath(docs / name, source)
            return f"{bang}[{text}]({pathlib.Path(served).as_posix()})"
        if name in REPOSITORY_PAGES:
            page_path = os.path.relpath(docs / REPOSITORY_PAGES[name], source)
            suffix = f"#{anchor}" if anchor else ""
            return f"{bang}[{text}]({pathlib.Path(page_path).as_posix()}{suffix})"
        if name in text:
            return text  # the text already names the file: [`benchmarks/README.md`](...)
        return f"{text} (`{name}`)"

    return LINK.sub(rewrite, markdown)
