"""README.md: short, its example prints what it shows, its links resolve, CI's command.

Its python blocks run with every docs page's in tests/test_docs.py.
"""

import contextlib
import io
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def test_readme_is_short():
    assert len(README.read_text().splitlines()) <= 150


def test_readme_example_prints_what_it_shows():
    text = README.read_text()
    section = text.split("## A first search")[1].split("\n## ")[0]
    example = re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]
    (shown,) = re.findall(r"```text\n(.*?)```", section, flags=re.S)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(example, str(README), "exec"), {})
    assert out.getvalue() == shown


def test_links_resolve():
    pages = [README, ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]
    for page in pages:
        for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", page.read_text()):
            if target.startswith("http"):
                continue
            assert (page.parent / target).exists(), (page.name, target)


def test_readme_names_the_command_ci_runs():
    # CI's first pytest command is the whole suite (on the newest JAX); the second,
    # the oldest JAX's subset, is CI's own.
    whole, subset = re.findall(r"^python -m pytest .*$", (ROOT / ".ci" / "run").read_text(), re.M)
    assert README.read_text().count(whole) >= 2  # set-up and development
    assert "OLDEST_SUBSET" in subset


def test_every_docs_page_is_listed_on_the_home_page():
    index = (ROOT / "docs" / "index.md").read_text()
    for page in sorted((ROOT / "docs").rglob("*.md")):
        if page.name != "index.md":
            assert f"({page.relative_to(ROOT / 'docs').as_posix()})" in index, page
