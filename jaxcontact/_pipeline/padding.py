"""Plain calls run at a few padded shapes, so a long process compiles few programs.

Every XLA program the CPU backend compiles maps about three memory regions
per kernel into the process (code, read-only data, data), and a detector's
program has 40-200 kernels: 150-600 maps per program, freed only by
``jax.clear_caches()``. A process that calls a detector at hundreds of
shapes (a sweep over mesh sizes, a notebook, a test suite) reaches the
kernel's ``vm.max_map_count`` (65,530 by default) and XLA's compiler
crashes (measured with commit 5928bf7f76cc:benchmarks/archive/long_process.py).

So the one-call detectors, called plainly on concrete arrays, pad the
slaves, the segments and the master nodes up to a size class (``size_class``:
four classes per doubling, at most 1/4 more rows) with masked padding, run
the program compiled for that class, and cut the rows back. Real rows are
unchanged: padding never changes a real row (the repository's
docs/contract.md). Under ``jit``, ``vmap`` or ``grad`` the caller's program
is compiled once at the caller's shapes anyway, and nothing is padded.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._pipeline.sizes import size_class
from jaxcontact._types import Surface

# Scenes at least this small share one padded shape: their programs cost
# the same to run, and tests and notebooks make many of them.
SMALLEST_ROWS = 16
SMALLEST_SEGMENTS = 8


def _traced(*values) -> bool:
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(values))


def _on_several_devices(*values) -> bool:
    return any(
        isinstance(leaf, jax.Array) and len(leaf.sharding.device_set) > 1
        for leaf in jax.tree.leaves(values)
    )


def _on_cpu(*values) -> bool:
    if _traced(values):
        return False
    return all(
        not isinstance(leaf, jax.Array) or next(iter(leaf.sharding.device_set)).platform == "cpu"
        for leaf in jax.tree.leaves(values)
    )


def _pad(values, length: int, fill, module=jnp):
    """``values`` with rows of ``fill`` appended up to ``length`` rows."""
    if values is None:
        return None
    # Always ``module``'s arrays: jit caches NumPy and device arguments apart.
    values = module.asarray(values)
    if module is np:  # a copy into a filled array: np.pad costs 10-20 us a call
        padded = np.full((length, *values.shape[1:]), fill, values.dtype)
        padded[: values.shape[0]] = values
        return padded
    pad = [(0, length - values.shape[0])] + [(0, 0)] * (values.ndim - 1)
    return module.pad(values, pad, constant_values=fill)


def _row_mask(mask, num_rows: int, length: int, module):
    """bool[length]: ``mask`` (or all True) for the real rows, False for padding."""
    if mask is None:
        mask = np.ones((num_rows,), bool)
    return _pad(mask, length, False, module)


def _pad_arrays(
    slaves, mask, surface: Surface, extras, rows: int, segments: int, nodes: int, module
):
    num_rows, num_segments = slaves[0].shape[0], surface.segments.shape[0]
    slaves = tuple(_pad(values, rows, 0, module) for values in slaves)
    extras = jax.tree.map(lambda values: _pad(values, rows, 0, module), extras)
    mask = _row_mask(mask, num_rows, rows, module)
    segment_mask = _row_mask(surface.mask, num_segments, segments, module)
    nodes, body, segments = (
        _pad(surface.nodes, nodes, 0, module),
        _pad(surface.body, segments, 0, module),
        _pad(surface.segments, segments, 0, module),
    )
    return slaves, mask, Surface(nodes, segments, segment_mask, body), extras


# Arrays on an accelerator are padded there, in one small program (op by op,
# each pad would be a program of its own).
_pad_on_device = jax.jit(
    functools.partial(_pad_arrays, module=jnp), static_argnames=("rows", "segments", "nodes")
)


def pad_scene(slaves: tuple, mask, surface: Surface, extras=None, others=None):
    """``(slaves, mask, surface, extras, num_rows)`` padded to their size classes.

    ``slaves`` are the checked f[N, 2] arrays of one query (``(x,)`` or
    ``(x_prev, x)``); ``extras`` a pytree of other per-row arrays (a radius
    per slave, the pair rule), padded with zeros; ``others`` the call's
    remaining arguments, not padded. Returns them unchanged, with
    ``num_rows = None``, when padding would not help: any argument traced
    (the caller's program is compiled at its own shapes), arrays spread over
    several devices, empty scenes.
    """
    num_rows, num_segments = slaves[0].shape[0], surface.segments.shape[0]
    num_nodes = surface.nodes.shape[0]
    rows = size_class(num_rows, SMALLEST_ROWS)
    segments = size_class(num_segments, SMALLEST_SEGMENTS)
    nodes = size_class(num_nodes, SMALLEST_SEGMENTS)
    everything = (slaves, mask, surface, extras, others)
    # Scenes already at their class are passed the same way (with a row
    # mask), so that they share its program too.
    if num_rows == 0 or num_segments == 0 or _traced(everything) or _on_several_devices(everything):
        return slaves, mask, surface, extras, None
    # On the CPU, NumPy pads without compiling anything.
    on_cpu = _on_cpu(slaves, mask, surface, extras)
    pad = functools.partial(_pad_arrays, module=np) if on_cpu else _pad_on_device
    padded = pad(slaves, mask, surface, extras, rows=rows, segments=segments, nodes=nodes)
    return *padded, num_rows


@functools.partial(jax.jit, static_argnames="num_rows")
def _first_rows(result, num_rows: int):
    return jax.tree.map(lambda values: values[:num_rows] if values.ndim else values, result)


def cut_rows(result, num_rows: int | None):
    """``result`` with its per-row fields cut back to ``num_rows`` rows."""
    if num_rows is None:
        return result
    if not _on_cpu(result):
        return _first_rows(result, num_rows=num_rows)
    # On the CPU: host views, cut, and back as the arguments of a program that
    # returns them (copies only: no kernel is compiled, nothing is mapped).
    # A jitted argument costs microseconds; jax.device_put about 0.1 ms an
    # array (measured with commit 5928bf7f76cc:benchmarks/archive/one_call.py).
    cut = jax.tree.map(
        lambda values: np.asarray(values)[:num_rows] if values.ndim else values, result
    )
    return to_device(cut)


# A program of copies: host arrays in, device arrays out.
to_device = jax.jit(lambda tree: tree)


def cut_entries(entries, num_rows: int | None):
    """A ``ContactList`` or ``CrossingList`` of padded rows with its padding
    entries naming ``num_rows``."""
    if num_rows is None:
        return entries
    real = entries.found if hasattr(entries, "found") else entries.crossed
    if not _on_cpu(entries):
        return entries._replace(node=_renamed(entries.node, real, num_rows))
    node = np.where(np.asarray(real), np.asarray(entries.node), num_rows)
    return entries._replace(node=to_device(node.astype(np.int32)))


@jax.jit
def _renamed(node, found, num_rows):
    return jnp.where(found, node, num_rows).astype(jnp.int32)
