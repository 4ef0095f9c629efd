"""A list in the docs renders as a list.

Python-Markdown (mkdocs) starts a list only after a blank line: ``- item`` lines that
directly follow a paragraph line are read as more of that paragraph, and the site shows them
as literal text. The site is built only where the docs extra is installed, so the rule is
checked here on the Markdown itself.
"""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^( *)```(\S*)\n(.*?)^\1```", re.S | re.M)
ITEM = re.compile(r"^ *([-*+]|\d+\.) ")
# A block that starts with one of these is not a paragraph: a heading, a table, HTML, or
# content nested in the list item above it (Python-Markdown nests at four spaces; a block
# indented by two after a blank line is a paragraph of its own, and ends the list).
NOT_PROSE = ("#", "|", "<", "    ")


def glued_lists(text: str) -> list[int]:
    """The 1-based lines where a list item follows a paragraph line with no blank between."""
    # Code blocks may hold anything: blanked, keeping the line count.
    text = FENCE.sub(lambda match: "\n" * match.group(0).count("\n"), text)
    lines = text.split("\n")
    found = []
    for k, line in enumerate(lines):
        if not ITEM.match(line) or k == 0 or not lines[k - 1].strip():
            continue
        start = k - 1
        while start > 0 and lines[start - 1].strip():
            start -= 1
        block = lines[start:k]
        if not any(ITEM.match(row) for row in block) and not block[0].startswith(NOT_PROSE):
            found.append(k + 1)
    return found


def test_the_rule_finds_a_list_glued_to_a_paragraph():
    glued = "Some prose.\n- an item\n"
    assert glued_lists(glued) == [2]
    assert glued_lists("Some prose.\n\n- an item\n- another\n  continued\n") == []
    assert glued_lists("- an item\n\n    its second paragraph\n- the next item\n") == []
    assert glued_lists("- an item\n\n  ends the list\n- literal text\n") == [4]
    assert glued_lists("```text\nprose\n- not markdown\n```\n") == []


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.relative_to(ROOT).as_posix())
def test_every_list_starts_after_a_blank_line(page):
    assert glued_lists(page.read_text()) == [], f"{page.name}: add a blank line before the list"
