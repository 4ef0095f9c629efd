"""Checking and sanitising the inputs every detector shares.

Shapes and dtypes are checked at trace time and raise ``ValueError`` naming
the argument. Values are checked only where they are concrete (outside
``jit``): real segments' indices in range, a radius that is finite and
non-negative. Masked segments are padding, and their indices are never
checked (``-1`` is the usual sentinel). Under ``jit`` a bad value cannot
raise, so it is neutralised instead: a slave with a NaN or inf coordinate is
treated as masked, a segment touching such a node or with an index out of
range as masked, and both are replaced by zeros before any arithmetic so
that nothing NaN reaches a value or a gradient.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact._types import Array, Surface


def is_concrete(value) -> bool:
    return not isinstance(value, jax.core.Tracer)


def as_array(values, dtype=None):
    """``values`` as an array of ``dtype`` (the dtype JAX computes in: float64
    becomes float32 with x64 off), without a transfer for host data.

    NumPy arrays and Python or NumPy scalars stay NumPy arrays: a jitted
    program takes them as arguments for a few microseconds each, where
    ``jnp.asarray`` puts each on the device apart (about 0.1 ms on the CPU,
    measured with commit 5928bf7f76cc:benchmarks/archive/one_call.py). JAX arrays
    and tracers go through ``jnp.asarray``.
    """
    if isinstance(values, jax.Array | jax.core.Tracer):
        if dtype is None or values.dtype == dtype:
            return values
        return jnp.asarray(values, dtype)
    values = np.asarray(values)
    wanted = values.dtype if dtype is None else np.dtype(dtype)
    return np.asarray(values, jax.dtypes.canonicalize_dtype(wanted))


def _describe(value) -> str:
    return f"shape {tuple(np.shape(value))} and dtype {jnp.result_type(value)}"


# The forms that take 2D input alone say so to a 3D array: which form does take it.
ONLY_2D = (
    "3D input is supported by all_to_all in this release; the bucket sort, Search, swept, "
    "the pair rules, smooth normals, the forces and the slip history take 2D input "
    "(f[N, 2]) for now"
)


def check_2d_result(name: str, contact) -> None:
    """A ``ValueError`` for a 3D result (``normal`` f[..., 3]) passed where only a 2D one
    is served (the forces, the slip history): a 3D face has three nodes to spread a
    reaction on and a tangent plane to slip in, which these do not yet read."""
    normal = getattr(contact, "normal", None)
    if normal is not None and np.shape(normal)[-1:] == (3,):
        raise ValueError(
            f"{name} is a 3D result (normal of shape {tuple(np.shape(normal))}): {ONLY_2D}"
        )


def check_points(name: str, points, dtype=None, dimensions: tuple[int, ...] = (2,)) -> Array:
    """Checks ``points`` is f[N, d] for a ``d`` in ``dimensions`` (of ``dtype``
    if given) and returns it as an array."""
    if not hasattr(points, "dtype"):
        points = jnp.asarray(points)
    # float16 and bfloat16 are refused too: the error bounds the tests state
    # (and the exact ties at vertices) are for float32 and float64.
    computed = jax.dtypes.canonicalize_dtype(points.dtype)
    kind = "f" if computed in (np.float32, np.float64) else "other"
    if np.ndim(points) != 2 or np.shape(points)[-1] not in dimensions:
        if np.ndim(points) == 2 and np.shape(points)[-1] == 3:
            raise ValueError(f"{name} must have shape (N, 2); got {_describe(points)}: {ONLY_2D}")
        wanted = " or ".join(f"(N, {d})" for d in dimensions)
        raise ValueError(f"{name} must have shape {wanted}; got {_describe(points)}")
    if kind != "f":
        raise ValueError(
            f"{name} must be a real floating array (float32 or float64); got {_describe(points)}"
        )
    # NumPy float64 arrays become float32 when x64 is off, as ``x`` did: compare
    # the dtypes JAX will compute in, not the ones passed.
    if dtype is not None and computed != dtype:
        raise ValueError(
            f"{name} must have the slaves' dtype {np.dtype(dtype)}; got {_describe(points)}"
        )
    return as_array(points, computed)


def check_mask(name: str, mask, length: int) -> Array | None:
    """Checks an optional boolean row mask of length ``length``."""
    if mask is None:
        return None
    if not hasattr(mask, "dtype"):
        mask = np.asarray(mask)
    if np.shape(mask) != (length,) or mask.dtype != np.bool_:
        raise ValueError(
            f"{name} must have shape ({length},) and dtype bool; got {_describe(mask)}"
        )
    return as_array(mask)


def check_segments(segments, dimension: int = 2):
    """Checks ``surface.segments`` is i[M, 2] (segments; i[M, 3] triangles
    for a ``dimension`` of 3), shape and dtype only; returns it."""
    if not hasattr(segments, "dtype"):
        segments = np.asarray(segments)
    if np.ndim(segments) != 2 or np.shape(segments)[-1] != dimension:
        what = " (triangles, as the nodes are 3D)" if dimension == 3 else ""
        raise ValueError(
            f"surface.segments must have shape (M, {dimension}){what}; got {_describe(segments)}"
        )
    if np.dtype(segments.dtype).kind not in "iu":
        raise ValueError(f"surface.segments must be an integer array; got {_describe(segments)}")
    return segments


def _check_real_indices(segments, mask, num_nodes: int):
    """Raises when a real segment's index lies outside ``[0, num_nodes)``.

    Only where the indices and the mask are concrete: with either traced,
    the real segments are not known here, and an index out of range makes
    the segment padding instead (``segments.resolve_segments``).
    """
    if not (is_concrete(segments) and is_concrete(mask)):
        return
    values = np.asarray(segments)
    if mask is not None:
        values = values[np.asarray(mask)]
    if not values.size:
        return
    low, high = int(values.min()), int(values.max())
    if low < 0 or high >= num_nodes:
        real = "" if mask is None else ", where surface.mask is True"
        raise ValueError(
            f"surface.segments must index surface.nodes, in [0, {num_nodes - 1}]{real}; "
            f"got values in [{low}, {high}]"
        )


def _as_int32(segments, num_nodes: int):
    """``segments`` as int32, every index outside ``[0, num_nodes)`` still outside.

    Narrowing a wider integer wraps (int64 ``2**32`` would become node 0),
    which would turn an ignored index into a real node: such indices become
    ``-1`` first, compared in their own dtype.
    """
    if np.can_cast(segments.dtype, np.int32):
        return as_array(segments, np.int32)
    # NumPy input stays in NumPy: with x64 off, jnp would narrow it first.
    xp = np if isinstance(segments, np.ndarray) else jnp
    in_range = (segments >= 0) & (segments < num_nodes)
    return as_array(xp.where(in_range, segments.astype(np.int32), -1), np.int32)


def check_surface(surface: Surface, dtype, dimension: int = 2) -> Surface:
    """Checks a ``Surface`` against the slaves' ``dtype`` and ``dimension``
    (their coordinates per row); segments become int32."""
    if not isinstance(surface, Surface):
        raise ValueError(f"surface must be a jaxcontact.Surface; got {type(surface).__name__}")
    if dimension != 2 and np.ndim(surface.nodes) == 2 and np.shape(surface.nodes)[-1] != dimension:
        # x sets the dimension: the message starts from it.
        raise ValueError(
            f"x has {dimension} coordinates per row, so surface.nodes must have shape "
            f"(P, {dimension}) (2 for segments, 3 for triangles); got {_describe(surface.nodes)}"
        )
    if dimension == 2 and np.ndim(surface.nodes) == 2 and np.shape(surface.nodes)[-1] == 3:
        raise ValueError(
            "surface.nodes must have shape (P, 2), as x has 2 coordinates per row (3D input "
            f"has x of shape (N, 3) too); got {_describe(surface.nodes)}"
        )
    nodes = check_points("surface.nodes", surface.nodes, dtype, (dimension,))
    segments = check_segments(surface.segments, dimension)
    mask = check_mask("surface.mask", surface.mask, segments.shape[0])
    _check_real_indices(segments, mask, nodes.shape[0])
    body = check_labels("surface.body", surface.body, segments.shape[0], "M")
    return Surface(nodes, _as_int32(segments, nodes.shape[0]), mask, body)


def check_radius(radius, dtype, num_rows: int | None = None, mask=None) -> Array:
    """Checks ``radius``: a real scalar, or f[N] (one per slave) where
    ``num_rows`` is given; finite and >= 0 where concrete (masked rows' values
    may be anything)."""
    shape = tuple(np.shape(radius))
    if shape != () and (num_rows is None or shape != (num_rows,)):
        wanted = "a scalar" if num_rows is None else f"a scalar or shape ({num_rows},)"
        raise ValueError(f"radius must be {wanted}; got shape {shape}")
    if np.dtype(jnp.result_type(radius)).kind not in "fiu":
        raise ValueError(f"radius must be real; got dtype {jnp.result_type(radius)}")
    if is_concrete(radius) and is_concrete(mask):
        values = np.asarray(radius, np.float64).reshape(-1)
        if shape and mask is not None:
            values = values[np.asarray(mask)]
        bad = ~np.isfinite(values) | (values < 0)
        if bad.any():
            raise ValueError(f"radius must be finite and >= 0; got {values[bad][0]}")
    return as_array(radius, dtype)


def reach_of(radius: Array, ok: Array | None) -> Array:
    """f[]: the farthest any real row reaches: ``radius``, or its largest
    valid value over the rows ``ok`` (a per-slave radius). Under ``jit`` a
    real row's radius that is negative or not finite finds nothing, and
    reaches nothing here."""
    if radius.ndim == 0:
        return radius
    valid = jnp.isfinite(radius) & (radius >= 0)
    if ok is not None:
        valid = valid & ok
    return jnp.max(jnp.where(valid, radius, 0), initial=0)


def check_labels(name: str, labels, length: int, symbol: str = "N"):
    """Checks optional integer labels of shape ``(length,)``; returns int32 or None."""
    if labels is None:
        return None
    if not hasattr(labels, "dtype"):
        labels = np.asarray(labels)
    if np.shape(labels) != (length,) or np.dtype(labels.dtype).kind not in "iu":
        raise ValueError(
            f"{name} must have shape ({symbol},) = ({length},) and an integer dtype; "
            f"got {_describe(labels)}"
        )
    if np.can_cast(labels.dtype, np.int32):
        return as_array(labels, np.int32)
    # Wider labels are compared in their own dtype first: narrowing wraps.
    xp = np if isinstance(labels, np.ndarray) else jnp
    info = np.iinfo(np.int32)
    fits = (labels >= info.min) & (labels <= info.max)
    if is_concrete(labels) and not np.all(np.asarray(fits)):
        raise ValueError(f"{name} must fit in int32; got {_describe(labels)}")
    return as_array(xp.where(fits, labels, -1).astype(np.int32))


def check_contact_inputs(x, surface: Surface, radius, mask, dimensions: tuple[int, ...] = (2,)):
    """Checks the arguments of a closest-point detector; returns them as arrays.

    ``radius`` may be a scalar or f[N], one per slave; ``x`` has as many
    coordinates per row as one of ``dimensions`` (3D: ``all_to_all`` alone)."""
    x = check_points("x", x, dimensions=dimensions)
    mask = check_mask("mask", mask, x.shape[0])
    surface = check_surface(surface, x.dtype, x.shape[-1])
    return x, surface, check_radius(radius, x.dtype, x.shape[0], mask), mask


def check_path_inputs(x_prev, x, mask):
    """Checks a pair of slave positions and their mask; returns them as arrays."""
    x_prev = check_points("x_prev", x_prev)
    x = check_points("x", x, x_prev.dtype)
    if x.shape != x_prev.shape:
        raise ValueError(f"x must have x_prev's shape {x_prev.shape}; got shape {x.shape}")
    return x_prev, x, check_mask("mask", mask, x.shape[0])


def check_slaves(x, x_prev, mask):
    """Checks the slaves, with their previous positions when given: ``(x_prev, x, mask)``."""
    if x_prev is not None:
        return check_path_inputs(x_prev, x, mask)
    x = check_points("x", x)
    return None, x, check_mask("mask", mask, x.shape[0])


def require_2d(form: str, **arrays):
    """A ``ValueError`` naming ``form`` and the argument when one of ``arrays``
    (f[N, d]) has 3 coordinates per row: ``form`` takes 2D input alone."""
    for name, values in arrays.items():
        if np.ndim(values) == 2 and np.shape(values)[-1] == 3:
            raise ValueError(
                f"{name} must have shape (N, 2) in {form}; got {_describe(values)}: {ONLY_2D}"
            )


def require_concrete(name: str, values, hint: str | None = None):
    """A ``ValueError`` when ``values`` are traced: sizes are measured on the host."""
    if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(values)):
        hint = hint or (
            "use jaxcontact.Search (allocate once outside, then search.closest / "
            "search.swept inside)"
        )
        raise ValueError(
            f"{name} measures its sizes from concrete data, so it cannot run under jit, "
            f"vmap or grad of its inputs: {hint}"
        )
