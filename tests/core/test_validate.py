"""``validate``: concrete inputs checked eagerly, bad rows named."""

import re
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcontact import Surface, all_to_all, swept, validate
from jaxcontact.scenes import cutting_scene

X = np.array([[0.5, 0.25], [1.5, -0.5], [0.2, 0.1]])
NODES = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
SURFACE = Surface(NODES, np.array([[0, 1], [1, 2]], np.int32))


def test_good_inputs_pass_silently():
    scene = cutting_scene(500, 18.0, x_tip_prev=18.2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate(scene.x, scene.surface, radius=scene.radius)
        validate(scene.x, scene.surface, x_prev=scene.x_prev, mask=jnp.ones(len(scene.x), bool))


def bad(rows):
    mask = np.zeros(len(X), bool)
    mask[rows] = True
    return mask


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: validate(np.where(bad([1])[:, None], np.nan, X), SURFACE), "x has non-finite "
         "coordinates in real rows [1]"),
        (lambda: validate(X, SURFACE, x_prev=np.where(bad([0, 2])[:, None], np.inf, X)),
         "x_prev has non-finite coordinates in real rows [0, 2]"),
        (lambda: validate(X, SURFACE._replace(segments=np.array([[0, 1], [1, -1]]))),
         "surface.segments has indices outside [0, 2] in rows [1]"),
        (lambda: validate(X, SURFACE._replace(segments=np.array([[0, 3], [1, 2]]))),
         "surface.segments has indices outside [0, 2] in rows [0]"),
        (lambda: validate(X, SURFACE._replace(nodes=np.where(bad([2])[:, None], np.nan, NODES))),
         "surface.nodes are not finite at the ends of real segments rows [1]"),
        (lambda: validate(X, SURFACE, radius=-0.5), "radius must be finite and >= 0; got -0.5"),
        (lambda: validate(X, SURFACE, radius=np.nan), "radius must be finite and >= 0; got nan"),
        (lambda: validate(X[0], SURFACE), "x must have shape (N, 2)"),
        (lambda: validate(X + 0j, SURFACE), "x must be a real floating array"),
        (lambda: validate(X, SURFACE, mask=np.ones(2, bool)), "mask must have shape (3,)"),
        (lambda: validate(X, SURFACE._replace(mask=np.ones(2))), "surface.mask must have shape"),
        (lambda: validate(X, SURFACE, x_prev=X[:2]), "x must have x_prev's shape"),
        (lambda: validate(X, (NODES, SURFACE.segments)), "surface must be a jaxcontact.Surface"),
    ],
)  # fmt: skip
def test_bad_input_raises_naming_argument_and_rows(call, message):
    with pytest.raises(ValueError, match=f"^{re.escape(message)}"):
        call()


def test_long_lists_of_rows_are_cut_and_counted():
    x = np.full((40, 2), np.nan)
    with pytest.raises(ValueError, match=re.escape("rows [0, 1, 2, 3, 4, ... (40 rows in all)]")):
        validate(x, SURFACE)


def test_masked_rows_and_segments_may_hold_anything():
    x = np.where(bad([1])[:, None], np.nan, X)
    nodes = np.concatenate([NODES, [[np.inf, 0.0]]])
    surface = Surface(nodes, np.array([[0, 1], [1, 3]], np.int32), np.array([True, False]))
    validate(x, surface, radius=0.5, mask=~bad([1]), x_prev=X)
    # ... and the detectors agree that such rows are harmless.
    assert np.isfinite(np.asarray(all_to_all(x, surface, radius=0.5, mask=~bad([1])).gap)).all()


def test_zero_length_segment_warns_naming_it():
    # The chain listed with its normals towards X (which lies inside the bend).
    surface = SURFACE._replace(segments=np.array([[2, 1], [2, 2], [1, 0]], np.int32))
    with pytest.warns(UserWarning, match=re.escape("surface.segments rows [1] have zero length")):
        validate(X, surface)
    # Legal: the detectors ignore it, as validate says.
    assert (np.asarray(swept(X, X[::-1], surface).segment) != 1).all()


def test_traced_arguments_are_refused():
    with pytest.raises(ValueError, match="validate needs concrete arrays; x is traced"):
        jax.jit(lambda x: validate(x, SURFACE))(X)


SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
AROUND = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise


def test_a_closed_loop_listed_clockwise_warns_naming_its_segments():
    outside = np.array([[0.5, -0.05]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate(outside, Surface(SQUARE, AROUND), radius=0.1)
        validate(outside, Surface(SQUARE, AROUND[::-1, ::-1][:3]), radius=0.1)  # open: no loop
    # Reversed (clockwise), with a masked segment and a counter-clockwise loop beside it.
    nodes = np.concatenate([SQUARE, SQUARE + 3.0])
    segments = np.concatenate([[[-1, -1]], AROUND[::-1, ::-1], AROUND + 4])
    mask = np.ones(len(segments), bool)
    mask[0] = False
    surface = Surface(nodes, segments, mask=mask)
    with pytest.warns(
        UserWarning, match=re.escape("rows [1, 2, 3, 4] form a closed loop listed clockwise")
    ):
        validate(outside, surface, radius=0.1)
    # What it warns of: the gap of a slave outside the square comes out negative.
    assert (
        float(
            all_to_all(jnp.asarray(outside), Surface(SQUARE, AROUND[::-1, ::-1]), radius=0.1).gap[0]
        )
        < 0
    )


def test_float32_far_from_the_origin_warns_against_the_radius():
    shifted = Surface(SQUARE + 1e4, AROUND)
    x = np.array([[1e4 + 0.5, 1e4 - 0.005]])
    with pytest.warns(
        UserWarning, match=r"float32 numbers lie up to 0.0012 apart, 12 % of the radius 0.01"
    ):
        validate(
            x.astype(np.float32),
            shifted._replace(nodes=shifted.nodes.astype(np.float32)),
            radius=0.01,
        )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate(
            x.astype(np.float32) - 1e4, Surface(SQUARE.astype(np.float32), AROUND), radius=0.01
        )
        validate(x.astype(np.float32), shifted._replace(nodes=shifted.nodes.astype(np.float32)))
        if jax.config.jax_enable_x64:
            validate(x, shifted, radius=0.01)
    # A radius of 0 has no share to compare with: its own warning is the only one.
    with pytest.warns(UserWarning) as caught:
        validate(
            x.astype(np.float32),
            shifted._replace(nodes=shifted.nodes.astype(np.float32)),
            radius=0.0,
        )
    assert [str(w.message)[:30] for w in caught] == ["validate: a radius of 0 finds "]
