"""A griffe extension (mkdocstrings): a class field's trailing comment is its docstring.

jaxcontact's NamedTuples state each field's dtype and shape in a comment on the
field's line (``gap: Array  # f[N]  signed gap``). Griffe reads docstrings, not
comments, so without this the API reference would list the fields bare; reading
the comment keeps the source the one place those shapes are written.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize

import griffe

# The leading ``dtype[shape]`` of a field comment (``f[N, 2]``, ``i32[M]``, ``bool[]``).
SHAPE = re.compile(r"^(\w+\[[^\]]*\])\s*(.*)$", re.S)


class FieldComments(griffe.Extension):
    def on_attribute_instance(self, *, node, attr: griffe.Attribute, agent, **kwargs) -> None:
        # Only a class body's annotated fields without a docstring of their own; a
        # module constant's comment is usually about the code, not the value.
        if attr.docstring is not None or not isinstance(node, ast.AnnAssign):
            return
        if attr.parent is None or not attr.parent.is_class:
            return
        comment = _trailing_comment(attr.source)
        if comment:
            attr.docstring = griffe.Docstring(
                _as_markdown(comment), lineno=attr.lineno, parent=attr
            )


def _trailing_comment(source: str) -> str:
    """The comment on the statement's first line; the tokenizer skips a ``#`` in a string."""
    first = source.splitlines()[0] if source else ""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(first + "\n").readline))
    except (tokenize.TokenError, SyntaxError):
        return ""
    comments = [token.string for token in tokens if token.type == tokenize.COMMENT]
    return comments[0].lstrip("#").strip() if comments else ""


def _as_markdown(comment: str) -> str:
    """The shape as code (Markdown would read ``[N]`` as a link), then the words."""
    match = SHAPE.match(comment)
    if match is None:
        return comment
    shape, words = match.groups()
    return f"`{shape}`: {words}" if words else f"`{shape}`"
