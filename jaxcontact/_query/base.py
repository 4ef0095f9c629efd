"""The query protocol: what a search asks of each slave, apart from how it searches.

Every search in jaxcontact is one pipeline (``_pipeline``): check and pad
the inputs, tag the pairs the rule forbids, cull blocks of slaves against the
master's box, bin the segments in cells, score each kept slave against its
candidates and keep the lowest score, assemble the chosen pair into result
rows, and write those back into N rows or K entries. Only five things differ
between the closest point and the first crossing of a path, and a ``Query``
names them:

1. the **pair kernel**: one slave's score against one segment, lower is
   better, ``inf`` for none (a squared distance; a time of first hit);
2. the **reach**: how far from a segment a slave may be and still meet it
   (the box each slave culls with, the margin the segments are binned with,
   the unit of the self-contact window, and how ``Search.allocate``
   measures the query's sizes);
3. how a row **chooses** among its pairs: the lowest score, exact ties to
   the lower index, then the query's own tie rule in ``assemble``;
4. how the choice becomes **result rows** (``assemble``), and which kept
   rows may appear in a list of entries (``reportable``);
5. the **result types**, with the flag that says a row holds an answer.

The write-back into N rows or K entries reads only the result types' fields,
so it is the same for every query. A third query (say, the closest node of
the master: ``tests/core/test_query.py``) is a new subclass of ``Query``
and nothing else, if its result types follow the conventions the write-back
reads (``_pipeline.writeback``): a ``segment`` field (i32, -1 for none), the
flag named by ``flag``, ``overflow`` last; index fields named ``segment`` or
``vertex`` hold -1 where nothing was found, flags (``found``, ``active``,
``crossed``) False, ``point`` and ``normal`` are f[..., 2], other fields
f[...] zeros; the list type has a leading ``node`` (the slave row).

A query is a stateless singleton: hashable, passed to ``jit`` as static.
"""

from __future__ import annotations

import abc
from typing import ClassVar

from jaxcontact._pipeline.broad import Box
from jaxcontact._pipeline.segments import Segments
from jaxcontact._types import Array


class Query(abc.ABC):
    """One kind of question: a pair kernel, a reach, a choice, an assembly, a result type."""

    name: ClassVar[str]  # "closest" or "swept": names programs and error messages
    result: ClassVar[type]  # the N-row result (``Contact``, ``Crossing``)
    listing: ClassVar[type]  # the K-entry result (``ContactList``, ``CrossingList``)
    flag: ClassVar[str]  # the result's field that says a row holds an answer
    num_points: ClassVar[int]  # arrays of f[N, 2] per slave: 1 (a point) or 2 (a path)
    row_multiple: ClassVar[int] = 1  # the exhaustive search pads its rows to a multiple
    uses_radius: ClassVar[bool]  # scored within a radius (its sizes reach radius + skin)

    @abc.abstractmethod
    def check(self, points: tuple, surface, radius, mask):
        """``(points, surface, radius, mask)`` checked, as arrays (``ValueError`` naming
        the argument otherwise)."""

    @abc.abstractmethod
    def sizing(self, points: tuple, reach) -> dict:
        """``sizes.measure``'s keywords for this query beside ``x = points[-1]``:
        ``radius=reach`` (``radius + skin``) or ``x_prev=`` (a path's own box)."""

    @abc.abstractmethod
    def kernel(self, *row_and_edge) -> Array:
        """f[]: the score of one slave (its points) against one ``Edge``."""

    @abc.abstractmethod
    def sanitize(self, points: tuple, mask) -> tuple[tuple, Array]:
        """``(points with bad rows zeroed, bool[N] real rows)``."""

    @abc.abstractmethod
    def pair_reach(self, points: tuple, ok: Array, radius) -> Array:
        """f[] or f[N]: each slave's reach, the unit of the self-contact window."""

    @abc.abstractmethod
    def row_boxes(self, points: tuple, mask) -> tuple[Array, Array, Array | None]:
        """``(low, high, ok)``: each slave's box (f[N, 2] each) and the rows the
        cull may keep (``None``: all but masked ones)."""

    @abc.abstractmethod
    def inflate(self, points: tuple, radius, mask) -> Array:
        """f[]: the margin the master's segments are inflated by for the cull."""

    @abc.abstractmethod
    def cell_boxes(self, segments: Segments, kept: tuple, ok: Array, culled: Box) -> Box:
        """The segment boxes binned into cells (``culled``: the cull's boxes)."""

    @abc.abstractmethod
    def assemble(self, kept: tuple, segments: Segments, choice, radius, overflow, ok, ruling):
        """The ``result`` of slaves ``kept`` for their ``choice`` (i32[S], -1 for none).

        ``ruling`` is ``(rule, row tags)``: the pair rule the search applied."""

    @abc.abstractmethod
    def reportable(self, choice: Array, score: Array, ok: Array, segments: Segments, radius):
        """bool[S]: the kept rows that may hold an answer once assembled."""

    def __repr__(self) -> str:
        return f"<query {self.name}>"
