"""Every ``git show REV:PATH`` the docs write shows a file of this repository.

The docs cite scripts and results that left the tree (the benchmarks' archive, older runs)
by a commit and a path; a citation of a name the repository does not hold (a tag that was
never pushed) fails for every reader. Needs the repository's history: skipped in a shallow
clone or outside git.
"""

import pathlib
import re
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [
    ROOT / "README.md",
    ROOT / "CHANGELOG.md",
    ROOT / "benchmarks" / "README.md",
    *sorted((ROOT / "docs").rglob("*.md")),
]
CITED = re.compile(r"git show\s+([^\s:`]+):([\w./-]*[\w/])")


def git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)


def full_history() -> bool:
    if shutil.which("git") is None:
        return False
    shallow = git("rev-parse", "--is-shallow-repository")
    return shallow.returncode == 0 and shallow.stdout.strip() == "false"


def citations() -> list[tuple[str, str, str]]:
    """``(page, rev, path)`` of every ``git show REV:PATH`` in the pages (a line break may
    fall after ``git show``)."""
    return [
        (page.relative_to(ROOT).as_posix(), rev, path)
        for page in PAGES
        for rev, path in CITED.findall(page.read_text())
    ]


def test_the_pattern_reads_a_citation_across_a_line_break():
    text = "run `git show\n03fd21e:benchmarks/results/peers.md` and `git show abc:docs/x.py`."
    assert CITED.findall(text) == [("03fd21e", "benchmarks/results/peers.md"), ("abc", "docs/x.py")]


def test_the_docs_cite_something():
    assert len(citations()) > 5


@pytest.mark.skipif(not full_history(), reason="needs the repository's whole history")
def test_every_cited_file_is_in_the_repository():
    missing = [
        f"{page}: git show {rev}:{path}"
        for page, rev, path in citations()
        if git("cat-file", "-e", f"{rev}:{path}").returncode != 0
    ]
    assert missing == []
