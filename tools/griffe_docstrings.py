"""A griffe extension (mkdocstrings): jaxcontact's docstring conventions, as griffe reads them.

A class field's trailing comment documents it, and ``Example:`` is an examples section.

jaxcontact's NamedTuples state each field's dtype and shape in a comment on the
field's line (``gap: Array  # f[N]  signed gap``). Griffe reads docstrings, not
comments, so without this the API reference would list the fields bare; reading
the comment keeps the source the one place those shapes are written. The fields
become an ``Attributes:`` table under the class's description.

The docstrings head their doctests ``Example:``, which Google style (Napoleon) reads as
``Examples:``; griffe knows the plural only and would show the singular's doctest as
an admonition of quoted prose, so it is renamed before griffe parses it.
"""

from __future__ import annotations

import io
import re
import tokenize

import griffe

# The leading ``dtype[shape]`` of a field comment (``f[N, 2]``, ``i32[M]``, ``bool[]``).
SHAPE = re.compile(r"^(\w+\[[^\]]*\])\s*(.*)$", re.S)
EXAMPLE = re.compile(r"^(\s*)Example:\s*$", re.M)


class JaxcontactDocstrings(griffe.Extension):
    def on_instance(self, *, node, obj: griffe.Object, agent, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = EXAMPLE.sub(r"\1Examples:", obj.docstring.value)

    def on_class_members(self, *, node, cls: griffe.Class, agent, **kwargs) -> None:
        # A class body's annotated fields without a docstring of their own; a method's
        # or a constant's comment is usually about the code, not the value.
        fields = [
            (name, _trailing_comment(member.source))
            for name, member in cls.members.items()
            if member.is_attribute
            and not member.is_alias
            and member.annotation is not None
            and member.docstring is None
            and member.source.lstrip().startswith(f"{name}:")  # not self.name in a method
        ]
        fields = [(name, comment) for name, comment in fields if comment]
        if not fields:
            return
        text = cls.docstring.value if cls.docstring else ""
        if re.search(r"^\s*Attributes:\s*$", text, re.M):
            # The class lists its attributes itself: each comment stays with its field.
            for name, comment in fields:
                member = cls.members[name]
                member.docstring = griffe.Docstring(
                    _as_markdown(comment), lineno=member.lineno, parent=member
                )
            return
        # One table of the fields under the class's description, as an ``Attributes:``
        # section would give; the fields themselves stay undocumented, so mkdocstrings
        # (show_if_no_docstring: false) does not list them a second time, one heading each.
        section = "\n".join(f"    {name}: {_as_markdown(comment)}" for name, comment in fields)
        text = f"{text}\n\nAttributes:\n{section}" if text else f"Attributes:\n{section}"
        lineno = cls.docstring.lineno if cls.docstring else cls.lineno
        cls.docstring = griffe.Docstring(text, lineno=lineno, parent=cls)


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
