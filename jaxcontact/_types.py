"""The pytrees that go in and come out of every detector.

All four are ``NamedTuple``s, so they are immutable, registered with JAX as
pytrees (they pass through ``jit``, ``vmap``, ``grad`` and ``lax.scan``), and
unpack like tuples. Shapes below use ``N`` for slaves, ``P`` for master nodes
and ``M`` for master segments; ``f`` is the input's float dtype.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from typing import NamedTuple

import jax
import jax.numpy as jnp

Array = jax.Array


class Surface(NamedTuple):
    """The master: straight segments between nodes of one or more outlines.

    Segment ``k`` runs from ``nodes[segments[k, 0]]`` to ``nodes[segments[k, 1]]``;
    its outward normal is the tangent turned clockwise, so an outline listed
    counter-clockwise has normals pointing out of it. A masked segment is
    padding: its indices may be anything (``-1``, say), as may the nodes
    only masked segments use.

    ``body`` labels the outline each segment belongs to. With labels on the
    slaves too (``pairs=Pairs(slave_body=...)`` of every detector), a slave
    pairs only with the segments of other bodies (and, with
    ``Pairs(self_contact=True)``, with its own body's outside its
    neighbourhood along the outline): several
    deformable bodies are searched in one call.

    In 3D (``all_to_all`` alone in this release) ``nodes`` is f[P, 3] and
    ``segments`` holds triangles, i32[M, 3], each counter-clockwise seen from
    outside so that its normal ``(b - a) x (c - a)`` points out
    (docs/contract.md, "Contact in 3D").
    """

    nodes: Array  # f[P, 2]  master node coordinates (3D: f[P, 3])
    segments: Array  # i32[M, 2]  start and end node index of each segment (3D: i32[M, 3] triangles)
    mask: Array | None = None  # bool[M]  True for real segments; None means all real
    body: Array | None = None  # i32[M]  body label of each segment; None: no labels


class Contact(NamedTuple):
    """Closest-point contact, one row per slave.

    Rows that are not ``found`` (masked slaves, slaves farther than the radius
    from every real segment) hold zeros in ``gap``, ``xi``, ``point`` and
    ``normal`` and ``-1`` in ``segment`` and ``vertex``; these zeros carry
    zero gradient. ``vertex`` is the closest feature: the master node when
    the closest point is an end of the segment (decided by exact sign tests,
    never from ``xi``, which may round to 1 inside the face), ``-1`` on the
    face's interior.

    In 3D (slaves f[N, 3], triangles) ``xi`` is f[N, 2], the barycentric
    weights of the face's corners 1 and 2; ``point`` and ``normal`` are
    f[N, 3]; ``vertex`` is i32[N, 2], the closest feature's nodes:
    ``(-1, -1)`` on the face's interior, ``(v, -1)`` at a vertex, an edge's
    two nodes in increasing order (docs/contract.md, "Contact in 3D").
    """

    gap: Array  # f[N]  signed gap; negative is penetration
    xi: Array  # f[N]  projection coordinate on the chosen segment, in [0, 1]
    segment: Array  # i32[N]  chosen segment, -1 where not found
    point: Array  # f[N, 2]  closest point on the chosen segment
    normal: Array  # f[N, 2]  outward unit normal of the chosen segment
    vertex: Array  # i32[N]  master node at the closest point when it is an end, else -1
    found: Array  # bool[N]  a real segment lies within the radius
    active: Array  # bool[N]  found & (gap < 0)
    overflow: Array  # bool[]  a fixed capacity was too small; a contact may be missing


def _spread_rows(entries, dense: type, num_rows: int):
    """The N-row result (type ``dense``: ``Contact`` or ``Crossing``) of ``num_rows`` rows
    that compact ``entries`` describe: each field's entries put at rows
    ``entries.node`` of rows of nothing found (``-1`` for indices, else zero
    or False); entries naming row ``num_rows``, the padding, are dropped."""

    def put(name):
        values = getattr(entries, name)
        empty = -1 if name in ("segment", "vertex") else 0
        shape = (num_rows,) + values.shape[1:]
        return jnp.full(shape, empty, values.dtype).at[entries.node].set(values, mode="drop")

    rows = {name: put(name) for name in dense._fields if name != "overflow"}
    return dense(**rows, overflow=entries.overflow)


class ContactList(NamedTuple):
    """The found contacts only, packed into a fixed number of entries.

    The compact form of ``Contact`` (as jax-md's ``Sparse`` neighbour lists
    beside ``Dense``): entry ``j`` says that slave ``node[j]`` touches
    segment ``segment[j]``, with the gap, xi, point and normal of row
    ``node[j]`` of the ``Contact`` (equal to rounding: the last bit may
    differ). Found entries come first, in increasing ``node``; the entries
    after them are padding: ``node = N`` (one past the last slave, so
    ``x.at[node].add(f)`` and ``jax.ops.segment_sum(f, node, N)`` drop
    them), ``segment = vertex = -1``, zeros elsewhere, ``found`` False. The capacity
    ``K`` is static (``Search(compact=True)`` measures it at ``allocate``);
    ``overflow`` is True when more entries were needed than it holds (the
    contacts found, and any slave at the radius to within rounding), and
    then some contacts may be missing.
    """

    node: Array  # i32[K]  slave row of each entry; N in padding entries
    gap: Array  # f[K]  signed gap; negative is penetration
    xi: Array  # f[K]  projection coordinate on the segment, in [0, 1]
    segment: Array  # i32[K]  the segment, -1 in padding entries
    point: Array  # f[K, 2]  closest point on the segment
    normal: Array  # f[K, 2]  outward unit normal of the segment
    vertex: Array  # i32[K]  master node at the closest point when it is an end, else -1
    found: Array  # bool[K]  the entry holds a contact (False: padding)
    active: Array  # bool[K]  found & (gap < 0)
    overflow: Array  # bool[]  a capacity (K or another) was too small: a contact may be missing

    def to_contact(self, num_rows: int) -> Contact:
        """The N-row ``Contact`` of ``num_rows`` slaves (N, static) these entries describe."""

        return _spread_rows(self, Contact, num_rows)


class Crossing(NamedTuple):
    """First crossing of each slave's path ``x_prev -> x`` with the master.

    Rows that are not ``crossed`` hold ``t = 0``, ``point = 0`` and ``segment = -1``.
    """

    t: Array  # f[N]  path parameter of the first crossing, in [0, 1]
    segment: Array  # i32[N]  crossed segment, -1 where none
    point: Array  # f[N, 2]  where the path meets the segment: x_prev + t (x - x_prev)
    crossed: Array  # bool[N]  the path meets a real segment
    overflow: Array  # bool[]  a fixed capacity was too small; a crossing may be missing


class CrossingList(NamedTuple):
    """The crossed paths only, packed into a fixed number of entries.

    The compact form of ``Crossing``, as ``ContactList`` is of ``Contact``:
    entry ``j`` says that the path of slave ``node[j]`` first meets segment
    ``segment[j]`` at ``t[j]``, with the values of row ``node[j]`` of the
    ``Crossing`` (equal to rounding: the last bit may differ). Crossed entries
    come first, in increasing ``node``; the entries after them are padding:
    ``node = N``, ``segment = -1``, ``t = 0``, ``point = 0``, ``crossed``
    False. The capacity ``K`` is static (``Search(compact=True)`` measures it
    at ``allocate`` with ``x_prev``); ``overflow`` is True when more entries
    were needed than it holds (the paths the search chose a segment for),
    and then some crossings may be missing.
    """

    node: Array  # i32[K]  slave row of each entry; N in padding entries
    t: Array  # f[K]  path parameter of the first crossing, in [0, 1]
    segment: Array  # i32[K]  crossed segment, -1 in padding entries
    point: Array  # f[K, 2]  where the path meets the segment
    crossed: Array  # bool[K]  the entry holds a crossing (False: padding)
    overflow: Array  # bool[]  a capacity (K or another) was too small: a crossing may be missing

    def to_crossing(self, num_rows: int) -> Crossing:
        """The N-row ``Crossing`` of ``num_rows`` slaves (N, static) these entries describe."""

        return _spread_rows(self, Crossing, num_rows)


# With this many segments or fewer, each kept slave meets every segment: a
# running minimum over M broadcast segments beats per-slave candidate gathers
# (measured: commit 5928bf7f76cc:benchmarks/archive/bucket.py finds the crossover).
# ``Search(cells_above=...)``.
CELLS_ABOVE = 48
# Kept slaves are searched in chunks of this many rows, fullest lists first.
CHUNK_ROWS = 2048


@dataclasses.dataclass(frozen=True)
class Sizes:
    """Static sizes of a bucket sort: hashable, a static field of ``SearchState``.

    A change of any field compiles the detectors anew.

    Attributes:
      num_slaves: N, the slave count the sizes were measured for.
      block_size: slaves culled together (consecutive rows).
      block_capacity: most blocks kept near the master.
      for_paths: made for ``bucket_swept`` (path boxes) rather than ``bucket_sort``.
      use_cells: bin the segments in cells; False tests each kept slave
        against every segment.
      grid_shape: cells in x and in y.
      cell_size: smallest cell edge; cells grow when the region outgrows the grid.
      span: most cells a segment's inflated box may cover, in x and in y.
      cell_capacity: most segments one cell's list may hold.
      chunk_rows: kept slaves searched together, longest cell lists first.
      buckets: 0 gives each of the ``grid_shape`` cells its own list; more
        hashes the cells into that many lists (a grid of that many more
        cells than slaves would otherwise need wider cells).
      tile_capacity: most tiles of the cell search (``TILE`` kept slaves
        of one cell's list each); 0 gives one per kept slave, which cannot
        overflow.
      contact_capacity: entries of the compact result (``ContactList``,
        ``Search(compact=True)``); 0 (the default) returns the N-row form,
        a ``Contact`` of N rows.
    """

    num_slaves: int
    block_size: int
    block_capacity: int
    for_paths: bool = False
    use_cells: bool = False
    grid_shape: tuple[int, int] = (1, 1)
    cell_size: float = 0.0
    span: tuple[int, int] = (1, 1)
    cell_capacity: int = 1
    chunk_rows: int = CHUNK_ROWS
    contact_capacity: int = 0
    buckets: int = 0
    tile_capacity: int = 0

    def __post_init__(self):
        if isinstance(self.buckets, bool) or not isinstance(self.buckets, int) or self.buckets < 0:
            raise ValueError(
                f"Sizes.buckets must be an int >= 0 (0: a list per cell); got {self.buckets!r}"
            )

    @property
    def slave_capacity(self) -> int:
        """Slaves the narrow phase holds: ``block_capacity * block_size``."""
        return self.block_capacity * self.block_size


class QuerySizes(Mapping):
    """The ``Sizes`` of each query a ``Search`` was allocated for, by the query's
    name (``"closest"``, ``"swept"``): ``state.sizes``.

    Read-only and hashable, as a static field of ``SearchState`` must be; a
    ``dict`` of the same items converts (``QuerySizes(mapping)``), so
    ``search.init(x, surface, sizes={"closest": sizes})`` works as well as
    ``sizes=state.sizes``.
    """

    __slots__ = ("_items",)

    def __init__(self, sizes: Mapping[str, Sizes] | None = None):
        items = dict(sizes or {})
        for name, value in items.items():
            if not isinstance(name, str) or not isinstance(value, Sizes):
                raise ValueError(
                    "sizes must map a query's name to its Sizes (state.sizes); got "
                    f"{type(name).__name__} -> {type(value).__name__}"
                )
        object.__setattr__(self, "_items", tuple(sorted(items.items())))

    def __setattr__(self, name, value):
        raise AttributeError("QuerySizes is read-only")

    def __getitem__(self, name: str) -> Sizes:
        for key, value in self._items:
            if key == name:
                return value
        raise KeyError(name)

    def __iter__(self) -> Iterator[str]:
        return (key for key, _ in self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __eq__(self, other) -> bool:
        return isinstance(other, Mapping) and dict(self._items) == dict(other.items())

    def __hash__(self) -> int:
        return hash(self._items)

    def __reduce__(self):
        # Rebuilt through __init__: the slot cannot be set after it.
        return QuerySizes, (dict(self._items),)

    def __repr__(self) -> str:
        return f"QuerySizes({dict(self._items)!r})"
