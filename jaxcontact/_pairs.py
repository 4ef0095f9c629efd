"""Which slave may meet which segment: the one place where pairs are ruled out.

Every search scores a pair with a geometric kernel; ``ruled`` wraps that
kernel so that a pair the rule forbids scores ``inf`` (never chosen), and the
vertex tie rule asks ``allows`` before it hands a slave to the neighbouring
face. jax-md's neighbour lists have the same single hook
(``custom_mask_function``). Without slave nodes, slave bodies or
self-contact there is no rule and the kernels run as before.

The rule, for slave ``i`` and a real segment ``k``:

1. **Own node.** With ``slave_node`` given, ``i`` never meets a segment that
   has its own node as an end (it lies on it, at distance 0).
2. **Bodies.** With ``slave_body`` and ``surface.body`` both given, ``i``
   meets only other bodies' segments.
3. **Self-contact** (``self_contact=True``, which replaces rule 2): ``i``
   meets its own body's segments too, except those within its
   neighbourhood along the outline: the segments whose arc-length distance
   from ``i``'s node, along the chain of segments through it
   (``_outline``), is below ``SELF_CONTACT_REACH`` times its reach (the
   radius for closest points, the path's length for crossings).

Why arc length, and why that window (the reasons are in docs/contract.md):
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
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._inputs import Segments
from jaxcontact._outline import arc_distance, chains
from jaxcontact._types import Array

# The self-contact neighbourhood, in multiples of a slave's reach (above).
SELF_CONTACT_REACH = 4.0


@dataclasses.dataclass(frozen=True)
class Rule:
    """Which parts of the rule apply: static, decided by which inputs were given."""

    own_node: bool
    bodies: bool
    self_contact: bool


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=["slave_node", "slave_body"],
    meta_fields=["self_contact"],
)
@dataclasses.dataclass(frozen=True)
class Pairing:
    """The detectors' pair keywords, checked (``_inputs.check_pairing``)."""

    slave_node: Array | None = None  # i32[N]  surface node of each slave, -1 for none
    slave_body: Array | None = None  # i32[N]  body of each slave
    self_contact: bool = False

    def rule(self, body) -> Rule | None:
        """The ``Rule`` for a surface with labels ``body`` (or None): None if nothing applies."""
        rule = Rule(
            own_node=self.slave_node is not None,
            bodies=self.slave_body is not None and body is not None,
            self_contact=self.self_contact,
        )
        return rule if (rule.own_node or rule.bodies or rule.self_contact) else None


NO_PAIRING = Pairing()


class RowTags(NamedTuple):
    """Per slave, what the rule reads (fields the rule does not use are None)."""

    node: Array | None  # i32[N]  own node, -1 for none
    body: Array | None  # i32[N]
    chain: Array | None  # i32[N]  chain of the own node, -1 for none
    arc: Array | None  # f[N]  the own node's arc coordinate
    window: Array | None  # f[N]  arc length of the neighbourhood


class SegmentTags(NamedTuple):
    """Per segment, what the rule reads (fields the rule does not use are None)."""

    nodes: Array | None  # i32[M, 2]  end node indices
    body: Array | None  # i32[M]
    chain: Array | None  # i32[M]  -2 where not real
    low: Array | None  # f[M]  arc coordinate of the end node
    high: Array | None  # f[M]  arc coordinate of the start node
    loop: Array | None  # f[M]  the chain's length if closed, else inf


def tag(pairing: Pairing, segments: Segments, body, reach: Array):
    """``(rule, row tags, segments with their tags)`` for one search.

    ``reach`` (f[] or f[N]) is each slave's reach: the self-contact window is
    ``SELF_CONTACT_REACH`` times it. Tags carry no gradient. With no rule,
    ``(None, None, segments)``.
    """
    rule = pairing.rule(body)
    if rule is None:
        return None, None, segments
    num_nodes = segments.num_nodes
    node = body_of_row = chain = arc = window = None
    nodes = segment_body = segment_chain = low = high = loop = None
    if rule.own_node:
        node = pairing.slave_node
        node = jnp.where((node >= 0) & (node < num_nodes), node, -1).astype(jnp.int32)
        nodes = segments.indices
    if rule.bodies and not rule.self_contact:
        body_of_row, segment_body = pairing.slave_body, body
    if rule.self_contact:
        outline = chains(segments)
        at = jnp.maximum(node, 0)
        chain = jnp.where(node >= 0, outline.node_chain[at], -1) if num_nodes else node
        arc = outline.node_arc[at] if num_nodes else jnp.zeros(node.shape, reach.dtype)
        window = jnp.broadcast_to(SELF_CONTACT_REACH * reach, node.shape)
        segment_chain, low, high, loop = outline.chain, outline.low, outline.high, outline.loop
    rows = RowTags(node, body_of_row, chain, arc, window)
    tags = SegmentTags(nodes, segment_body, segment_chain, low, high, loop)
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
