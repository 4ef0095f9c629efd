"""Chains of segments joined end to start, and the arc length along them.

Self-contact must tell a body's own segments near a slave *along the
outline* (its neighbourhood: the corner it sits on) from those near it
*across* the body (a fold pressed onto it). Both are equally near in space;
only the arc length along the outline between them differs. It is measured
here under ``jit``, with no numbering assumed (outlines in any order,
several outlines, segments switched on or off since the last step).

Segment ``j`` follows segment ``k`` when it starts at ``k``'s end node
(``vertex_neighbours``, the lowest such index). Following that
link from any segment either ends (an open chain) or comes back (a closed
loop). Pointer jumping (Wyllie's list ranking: each round doubles how far
every pointer reaches, so ``log2`` of the longest chain rounds suffice)
gives every segment its chain and the arc length from its start to the
chain's end, in O(M log M) work and O(M) memory. A loop is cut open at its
lowest index first, found by the same doubling. Nodes joined to more than
two real segments (branches) are followed along the lowest index only.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxcontact._pipeline.segments import Segments
from jaxcontact._pipeline.sort import stable_order
from jaxcontact._types import Array

# Up to this many segments, ``_first_match`` uses the M x M table of matches.
TABLE_SEGMENTS = 128


class Chains(NamedTuple):
    """Arc-length coordinates along the outlines: ``u`` runs from a chain's
    end back to its start (a loop's coordinates lie in ``[0, loop]``)."""

    chain: Array  # i32[M]  chain of each real segment (its last segment); -2 where not real
    low: Array  # f[M]  u at the segment's end node
    high: Array  # f[M]  u at its start node (high - low = its length)
    loop: Array  # f[M]  the chain's length if it is a closed loop, inf if open
    node_chain: Array  # i32[P]  chain of each node, -1 on no real segment
    node_arc: Array  # f[P]  u of each node (0 on no real segment)


def _first_match(keys: Array, wanted: Array, exclude: Array, num_values: int) -> Array:
    """i32[M]: per k, the lowest j != exclude[k] with keys[j] == wanted[k], or -1.

    ``keys`` lie in ``[-1, num_values - 1)``. Up to ``TABLE_SEGMENTS``
    segments the M x M table of matches answers it in one fused pass and a
    reduction; past that, a sort and a binary search (O(M log M)), whose
    loop and gathers are most of a small outline's kernels.
    """
    num_keys = keys.shape[0]
    if num_keys <= TABLE_SEGMENTS:
        index = jnp.arange(num_keys, dtype=jnp.int32)
        match = (keys[None, :] == wanted[:, None]) & (index[None, :] != exclude[:, None])
        first = jnp.argmax(match, axis=1).astype(jnp.int32)
        return jnp.where(jnp.any(match, axis=1), first, -1)
    order = stable_order(keys + 1, num_values)
    ordered = keys[order]
    last = keys.shape[0] - 1
    at = jnp.minimum(jnp.searchsorted(ordered, wanted), last)
    # Skip over the excluded segment itself when it sorts first.
    skip = (order[at] == exclude) & (at < last)
    at = jnp.where(skip, at + 1, at)
    match = (ordered[at] == wanted) & (order[at] != exclude)
    return jnp.where(match, order[at], -1).astype(jnp.int32)


def vertex_neighbours(segments: Segments) -> tuple[Array, Array]:
    """``(before, after)``, i32[M] each: a segment ending at k's start node, one
    starting at k's end node (the lowest such index), -1 where none.

    O(M log M), by sorting the node indices: no M x M table.
    """
    index = jnp.arange(segments.indices.shape[0], dtype=jnp.int32)
    ok = segments.ok
    # Segments that are not real (padding, masked, degenerate) match nothing,
    # so padding can never change a real row: keys -1, wanted -2.
    starts, ends = segments.indices[:, 0], segments.indices[:, 1]
    num_values = segments.num_nodes + 1
    before = _first_match(jnp.where(ok, ends, -1), jnp.where(ok, starts, -2), index, num_values)
    after = _first_match(jnp.where(ok, starts, -1), jnp.where(ok, ends, -2), index, num_values)
    return before, after


def _jump(values, pointer):
    """``values`` read one pointer ahead; ``pointer`` -1 reads index 0 (masked by callers)."""
    return values[jnp.maximum(pointer, 0)]


def chains(segments: Segments) -> Chains:
    """The ``Chains`` of the real segments (values without gradient)."""
    start, end = jax.lax.stop_gradient((segments.start, segments.end))
    ok, indices = segments.ok, segments.indices
    num_segments, num_nodes = ok.shape[0], segments.num_nodes
    dtype = start.dtype
    if num_segments == 0:
        return Chains(
            jnp.zeros((0,), jnp.int32),
            *(jnp.zeros((0,), dtype),) * 3,
            jnp.full((num_nodes,), -1, jnp.int32),
            jnp.zeros((num_nodes,), dtype),
        )
    index = jnp.arange(num_segments, dtype=jnp.int32)
    successor = jnp.where(ok, vertex_neighbours(segments)[1], -1)
    length = jnp.where(ok, jnp.sqrt(jnp.sum((end - start) ** 2, axis=-1)), 0)

    # Loops: after ceil(log2(M + 1)) doublings a pointer on a chain has run off
    # its end (-1) and one on a loop has not; ``lowest`` is then the lowest
    # index on the loop, where it is cut open.
    def find_loops(_, carry):
        pointer, lowest = carry
        valid = pointer >= 0
        lowest = jnp.where(valid, jnp.minimum(lowest, _jump(lowest, pointer)), lowest)
        return jnp.where(valid, _jump(pointer, pointer), -1), lowest

    rounds = max(1, math.ceil(math.log2(num_segments + 1)))
    pointer, lowest = jax.lax.fori_loop(0, rounds, find_loops, (successor, index))
    in_loop = pointer >= 0
    successor = jnp.where(in_loop & (successor == lowest), -1, successor)

    # Suffix sums of the lengths, and each segment's last: until every pointer has run off.
    def rank(carry):
        pointer, arc, last = carry
        valid = pointer >= 0
        arc = arc + jnp.where(valid, _jump(arc, pointer), 0)
        last = jnp.where(valid, _jump(last, pointer), last)
        return jnp.where(valid, _jump(pointer, pointer), -1), arc, last

    _, arc, last = jax.lax.while_loop(
        lambda carry: jnp.any(carry[0] >= 0), rank, (successor, length, index)
    )
    loop = jnp.where(in_loop, arc[lowest], jnp.inf)
    chain = jnp.where(ok, last, -2)
    # Nodes: each segment's end node, then its start node (a loop's cut node
    # gets u = loop, the same place as u = 0 once distances wrap around).
    starts = jnp.where(ok, indices[:, 0], num_nodes)
    ends = jnp.where(ok, indices[:, 1], num_nodes)
    node_chain = jnp.full((num_nodes,), -1, jnp.int32)
    node_chain = node_chain.at[ends].set(chain, mode="drop").at[starts].set(chain, mode="drop")
    node_arc = jnp.zeros((num_nodes,), dtype)
    node_arc = node_arc.at[ends].set(arc - length, mode="drop").at[starts].set(arc, mode="drop")
    return Chains(chain, arc - length, arc, loop, node_chain, node_arc)


def arc_distance(at: Array, low: Array, high: Array, loop: Array) -> Array:
    """f[...]: arc length from coordinate ``at`` to the interval ``[low, high]``,
    the shorter way round on a loop of length ``loop`` (``inf``: an open chain)."""
    direct = jnp.maximum(jnp.maximum(low - at, at - high), 0)
    around = jnp.where(at < low, at + (loop - high), (loop - at) + low)
    return jnp.minimum(direct, around)
