"""Which slave may meet which segment: the one place where pairs are ruled out.

Every search scores a pair with a geometric kernel; ``ruled`` wraps that
kernel so that a pair the rule forbids scores ``inf`` (never chosen), and the
vertex tie rule asks ``allows`` before it hands a slave to the neighbouring
face. jax-md's neighbour lists have the same single hook
(``custom_mask_function``). Without slave nodes, slave bodies or
self-contact there is no rule and the kernels run unchanged.

The rule, for slave ``i`` and a real segment ``k``:

1. **Own node.** With ``slave_node`` given, ``i`` never meets a segment that
   has its own node as an end (it lies on it, at distance 0).
2. **Bodies.** With ``slave_body`` and ``surface.body`` both given, ``i``
   meets only other bodies' segments.
3. **Self-contact** (``self_contact=True``, which replaces rule 2): ``i``
   meets its own body's segments too, except those within its
   neighbourhood along the outline: the segments whose arc-length distance
   from ``i``'s node, along the chain of segments through it
   (``outline``), is below ``SELF_CONTACT_REACH`` times its reach (the
   radius for closest points, the path's length for crossings).

Why arc length, and why that window (the repository's docs/contract.md has more):
near a corner of its own outline a slave lies within the radius of the
faces beyond the corner, and behind them at a convex corner, so a plain
search reports a false penetration there. A segment on the other face of a
corner of interior angle ``theta``, at arc length ``s`` from the slave, is
at least ``s sin(theta / 2)`` from it (the chord of a wedge), so excluding
arc lengths below ``4 r`` leaves no pair within the radius ``r`` at any
corner sharper than 180 degrees down to ``2 asin(1/4) = 29`` degrees. A
fold pressed onto the slave comes from far along the outline and is kept.
LS-DYNA's single-surface contact and Radioss's type 7 exclude the
neighbouring segments by topology, as here; normals that oppose (the other
usual test) do not separate a sharp convex corner from a fold, whose faces
oppose too. What no local rule can tell apart is a part of the body
thinner than the radius: a slave there lies within the radius behind its
own body's opposite face, exactly as if it penetrated it. Keep the radius
below the thinnest part's thickness.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pipeline.inputs import check_labels, is_concrete
from jaxcontact._pipeline.outline import arc_distance, chains
from jaxcontact._pipeline.segments import Segments
from jaxcontact._types import Array, Surface

# The self-contact neighbourhood, in multiples of a slave's reach (above).
SELF_CONTACT_REACH = 4.0


@dataclasses.dataclass(frozen=True)
class Rule:
    """Which parts of the rule apply: static, decided by which inputs were given."""

    own_node: bool
    bodies: bool
    self_contact: bool
    allow: object = None  # the user's own rule (``Pairs.allow``), or None


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=["slave_node", "slave_body"],
    meta_fields=["self_contact", "allow"],
)
@dataclasses.dataclass(frozen=True)
class Pairs:
    """The pair rule: which slave may meet which segment (the rule above).

    One value, passed as ``pairs=`` to every detector and to ``Search``'s
    methods. The default, ``Pairs()``, lets every slave meet every real
    segment. A pytree: ``slave_node`` and ``slave_body`` are traced arrays
    (padded, batched and sharded with the slaves), ``self_contact`` is
    static.

    Attributes:
      slave_node: i32[N] or None: the index in ``surface.nodes`` that each
        slave is (-1 for none). A slave never meets a segment that has its
        own node as an end.
      slave_body: i32[N] or None: each slave's body. With ``surface.body``
        too, a slave meets only other bodies' segments.
      self_contact: a slave also meets its own body's segments, except
        those within its neighbourhood along the outline
        (``SELF_CONTACT_REACH`` times its reach: the radius, or a path's
        length). Needs ``slave_node``; with no body labels the whole surface
        is one body.
      allow: a rule of the user's own, the hook jax-md's neighbour lists
        call ``custom_mask_function``: ``allow(slave, segment) -> bool``,
        elementwise over i32 arrays of slave rows and segment indices of
        matching shape (write it with ``jnp``; it is traced). A pair meets
        only if ``allow`` and the rule above both let it. Static: hashed by
        identity, so pass the same function each step (a new one compiles
        anew). It may also be called on padding (rows past N, segments
        past M, empty slots); those answers are masked out.

    Example:
      >>> import jax.numpy as jnp
      >>> from jaxcontact import Pairs, Surface, all_to_all
      >>> square = Surface(
      ...     jnp.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
      ...     jnp.array([[0, 1], [1, 2], [2, 3], [3, 0]]),
      ... )
      >>> own = Pairs(slave_node=jnp.array([0, 1, 2, 3]))  # each corner is a slave
      >>> contact = all_to_all(square.nodes, square, radius=1.5, pairs=own)
      >>> contact.segment.tolist()  # the nearest segment not through its own corner
      [1, 2, 0, 0]
    """

    slave_node: Array | None = None  # i32[N]  surface node of each slave, -1 for none
    slave_body: Array | None = None  # i32[N]  body of each slave
    self_contact: bool = False
    allow: Callable[[Array, Array], Array] | None = None

    def rule(self, body) -> Rule | None:
        """The ``Rule`` for a surface with labels ``body`` (or None): None if nothing applies."""
        rule = Rule(
            own_node=self.slave_node is not None,
            bodies=self.slave_body is not None and body is not None,
            self_contact=self.self_contact,
            allow=self.allow,
        )
        applies = rule.own_node or rule.bodies or rule.self_contact or rule.allow is not None
        return rule if applies else None


EVERY_PAIR = Pairs()


class RowTags(NamedTuple):
    """Per slave, what the rule reads (fields the rule does not use are None)."""

    node: Array | None  # i32[N]  own node, -1 for none
    body: Array | None  # i32[N]
    chain: Array | None  # i32[N]  chain of the own node, -1 for none
    arc: Array | None  # f[N]  the own node's arc coordinate
    window: Array | None  # f[N]  arc length of the neighbourhood
    index: Array | None = None  # i32[N]  the slave's row, for ``Pairs.allow``


class SegmentTags(NamedTuple):
    """Per segment, what the rule reads (fields the rule does not use are None)."""

    nodes: Array | None  # i32[M, 2]  end node indices
    body: Array | None  # i32[M]
    chain: Array | None  # i32[M]  -2 where not real
    low: Array | None  # f[M]  arc coordinate of the end node
    high: Array | None  # f[M]  arc coordinate of the start node
    loop: Array | None  # f[M]  the chain's length if closed, else inf
    index: Array | None = None  # i32[M]  the segment's index, for ``Pairs.allow``


def tag(pairs: Pairs, segments: Segments, body, reach: Array, num_rows: int):
    """``(rule, row tags, segments with their tags)`` for one search of ``num_rows`` slaves.

    ``reach`` (f[] or f[N]) is each slave's reach: the self-contact window is
    ``SELF_CONTACT_REACH`` times it. Tags carry no gradient. With no rule,
    ``(None, None, segments)``.
    """
    rule = pairs.rule(body)
    if rule is None:
        return None, None, segments
    num_nodes = segments.num_nodes
    node = body_of_row = chain = arc = window = None
    nodes = segment_body = segment_chain = low = high = loop = None
    if rule.own_node:
        node = pairs.slave_node
        node = jnp.where((node >= 0) & (node < num_nodes), node, -1).astype(jnp.int32)
        nodes = segments.indices
    if rule.bodies and not rule.self_contact:
        body_of_row, segment_body = pairs.slave_body, body
    if rule.self_contact:
        outline = chains(segments)
        at = jnp.maximum(node, 0)
        chain = jnp.where(node >= 0, outline.node_chain[at], -1) if num_nodes else node
        arc = outline.node_arc[at] if num_nodes else jnp.zeros(node.shape, reach.dtype)
        window = jnp.broadcast_to(SELF_CONTACT_REACH * reach, node.shape)
        segment_chain, low, high, loop = outline.chain, outline.low, outline.high, outline.loop
    row_index = segment_index = None
    if rule.allow is not None:
        row_index = jnp.arange(num_rows, dtype=jnp.int32)
        segment_index = jnp.arange(segments.ok.shape[0], dtype=jnp.int32)
    rows = RowTags(node, body_of_row, chain, arc, window, row_index)
    tags = SegmentTags(nodes, segment_body, segment_chain, low, high, loop, segment_index)
    rows, tags = jax.lax.stop_gradient((rows, tags))
    return rule, rows, dataclasses.replace(segments, tags=tags)


def allows(rule: Rule | None, row: RowTags, segment: SegmentTags) -> Array:
    """bool[...]: the rule lets ``row`` meet ``segment`` (tags of one pair, or of
    pairs along matching leading axes)."""
    if rule is None:
        return jnp.ones((), bool)
    ok = jnp.ones((), bool)
    if rule.own_node:
        ends = segment.nodes
        ok = (ends[..., 0] != row.node) & (ends[..., 1] != row.node)
    if rule.self_contact:
        apart = arc_distance(row.arc, segment.low, segment.high, segment.loop)
        ok = ok & ~((row.chain == segment.chain) & (apart < row.window))
    elif rule.bodies:
        ok = ok & (row.body != segment.body)
    if rule.allow is not None:
        ok = ok & jnp.asarray(rule.allow(row.index, segment.index), bool)
    return ok


def ruled(kernel, rule: Rule | None):
    """The narrow phase's pair score: ``kernel(*row, edge)`` where ``rule``
    allows the pair, ``inf`` where it does not.

    The returned function takes ``(*row, row_tags, (edge, segment_tags))``.
    """

    def score(*args):
        *row, row_tags, (edge, segment_tags) = args
        value = kernel(*row, edge)
        if rule is None:
            return value
        return jnp.where(allows(rule, row_tags, segment_tags), value, jnp.inf)

    return score


def pick(tags, index: Array):
    """Row or segment tags (or None) at ``index`` (in range)."""
    if tags is None:
        return None
    return jax.tree.map(lambda values: values[index], tags)


def given(pairs) -> Pairs:
    """``pairs`` as passed (a ``Pairs``, or None for every pair), its type checked."""
    pairs = EVERY_PAIR if pairs is None else pairs
    if not isinstance(pairs, Pairs):
        raise ValueError(f"pairs must be a jaxcontact.Pairs; got {type(pairs).__name__}")
    return pairs


def check(pairs, x, surface: Surface, mask) -> Pairs:
    """``pairs`` (a ``Pairs``, or None for every pair) checked against the
    slaves ``x`` (f[N, 2]), the master ``surface`` and the slave ``mask``."""
    pairs = given(pairs)
    if not isinstance(pairs.self_contact, bool):
        raise ValueError(f"Pairs.self_contact must be a bool; got {pairs.self_contact!r}")
    if pairs.self_contact and pairs.slave_node is None:
        raise ValueError(
            "Pairs(self_contact=True) needs slave_node= (i32[N]: the surface node each slave "
            "is, -1 for none): a slave's neighbourhood is measured from its own node"
        )
    num_rows, num_nodes = x.shape[0], surface.nodes.shape[0]
    slave_node = check_labels("Pairs.slave_node", pairs.slave_node, num_rows)
    slave_body = check_labels("Pairs.slave_body", pairs.slave_body, num_rows)
    if slave_node is not None and is_concrete(slave_node) and is_concrete(mask):
        values = np.asarray(slave_node)
        if mask is not None:
            values = values[np.asarray(mask)]
        bad = (values < -1) | (values >= num_nodes)
        if bad.any():
            raise ValueError(
                f"Pairs.slave_node must be -1 or index surface.nodes, in [-1, {num_nodes - 1}]; "
                f"got {int(values[bad][0])}"
            )
    if pairs.allow is not None and not callable(pairs.allow):
        raise ValueError(f"Pairs.allow must be a function or None; got {pairs.allow!r}")
    return Pairs(slave_node, slave_body, pairs.self_contact, pairs.allow)
