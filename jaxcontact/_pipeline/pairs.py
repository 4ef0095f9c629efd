"""Which slave may meet which segment: the one place where pairs are ruled out.

The rule itself, a ``jaxcontact.Pairs`` and the ``Rule`` it decides, is
``jaxcontact._pairs``'s (with why it is so). This stage applies it: every
search scores a pair with a geometric kernel; ``ruled`` wraps that kernel so
that a pair the rule forbids scores ``inf`` (never chosen), and the vertex
tie rule asks ``allows`` before it hands a slave to the neighbouring face.
jax-md's neighbour lists have the same single hook
(``custom_mask_function``). Without slave nodes, slave bodies or
self-contact there is no rule and the kernels run unchanged.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pairs import SELF_CONTACT_REACH, Pairs, Rule
from jaxcontact._pipeline.inputs import ONLY_2D, check_labels, is_concrete
from jaxcontact._pipeline.outline import arc_distance, chains
from jaxcontact._pipeline.segments import Segments
from jaxcontact._types import Array, Surface

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
    if x.shape[-1] == 3:
        given_fields = [
            name
            for name, value in (
                ("slave_node", pairs.slave_node),
                ("slave_body", pairs.slave_body),
                ("allow", pairs.allow),
            )
            if value is not None
        ] + (["self_contact"] if pairs.self_contact is not False else [])
        if given_fields:
            raise ValueError(
                f"pairs must be None (or Pairs()) with x of shape {tuple(x.shape)}; got Pairs "
                f"with {', '.join(given_fields)}: {ONLY_2D}"
            )
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
