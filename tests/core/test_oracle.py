"""Both exhaustive queries against the brute-force oracle, one test per check.

``all_to_all`` (closest points) and ``swept`` (crossings) answer different
questions but are checked the same way: random scenes of every small size,
scenes without masks, everything masked, padding with non-finite rows and
float32 far from the origin. Each test runs over ``QUERIES``, whose runners
are those of the query's own file (``checked_scene``: the jitted detector
and the field-by-field comparison with the oracle), so both files' special
cases and these tests share one compiled program per shape. The special
cases of docs/contract.md stay in tests/core/test_all_to_all.py and
tests/core/test_swept.py.
"""

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import pytest

from tests.core import test_all_to_all, test_swept
from tests.support import helpers

# All of this file runs again with x64 off (tests/test_x64_off.py), the
# sweep over random scenes' sizes at one size.
pytestmark = pytest.mark.x64_off

ON_X64 = pytest.mark.skipif(not helpers.X64, reason="x64 off runs the 9-5 size only")

# Half-width of the far-from-origin scenes' box (``helpers.random_scene``'s scale).
FAR_SCALE = 2.0


class Query(NamedTuple):
    check: Callable  # (scene, **tolerance) -> result, checked against the oracle
    outcome: str  # the bool field that says a row has an answer
    flags: tuple[str, ...]  # bool fields, False on a row without an answer
    values: tuple[str, ...]  # float fields, zero on a row without an answer
    # The comparison's ``scale`` on FAR_SCALE scenes: the closest point's errors
    # grow with the local geometry; a crossing time's with the geometry over the
    # path length, which scaling both leaves at 1.
    far_scale: float


QUERIES = {
    "all_to_all": Query(
        test_all_to_all.checked_scene,
        "found",
        ("found", "active"),
        ("gap", "xi", "point", "normal"),
        FAR_SCALE,
    ),
    "swept": Query(test_swept.checked_scene, "crossed", ("crossed",), ("t", "point"), 1.0),
}
EACH_QUERY = pytest.mark.parametrize("query", QUERIES.values(), ids=QUERIES.keys())


# Sizes in the widest float only (float32 random scenes are compared below
# and in test_transforms.py): each size is a compilation. With x64 off
# (tests/test_x64_off.py), the largest only: what x64 changes is the index
# dtypes, not the shapes, and empty inputs run with x64 off in
# tests/core/test_validation.py.
@EACH_QUERY
@pytest.mark.parametrize(
    "num_slaves, num_segments",
    [
        pytest.param(n, m, marks=[] if (n, m) == (9, 5) else ON_X64)
        for n in (0, 1, 9)
        for m in (0, 1, 5)
    ],
)
def test_matches_oracle_on_random_masked_scenes(query, num_slaves, num_segments):
    for seed in range(4):
        query.check(helpers.random_scene(seed, num_slaves, num_segments, masked=True))


@EACH_QUERY
def test_matches_oracle_on_random_scenes_without_masks(query):
    answered = 0
    for seed in range(4):
        result = query.check(helpers.random_scene(seed, 9, 5))
        answered += int(getattr(result, query.outcome).sum())
    # The scenes must exercise both outcomes for the comparison to mean anything.
    assert 0 < answered < 4 * 9


@EACH_QUERY
@pytest.mark.parametrize("masked", ["slaves", "segments"])
def test_everything_masked_answers_nothing(query, masked):
    # A radius that reaches everything, so that only the masks keep rows out
    # (swept has no radius and ignores it).
    result = query.check(helpers.everything_masked(masked)._replace(radius=100.0))
    for flag in query.flags:
        assert not getattr(result, flag).any(), flag
    np.testing.assert_array_equal(result.segment, np.full(9, -1))
    for name in query.values:
        field = getattr(result, name)
        np.testing.assert_array_equal(field, np.zeros_like(field), name)


@EACH_QUERY
@pytest.mark.parametrize("fill", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
def test_nan_and_inf_padding_leaves_real_rows_unchanged(query, fill):
    helpers.assert_padding_leaves_real_rows_unchanged(
        query.check, fill, query.values + query.flags, query.outcome
    )


@EACH_QUERY
@pytest.mark.parametrize("offset", [1e4, 1e6])
def test_float32_far_from_origin_keeps_local_accuracy(query, offset):
    # The oracle runs in float64 on the very same float32 inputs, so it is the
    # exact answer for them. Gaps, projections and crossing times are functions
    # of differences of nearby inputs (exact in float32 by Sterbenz's lemma), so
    # their error can stay at a few ulps of the local geometry, whatever the
    # offset. A point is a coordinate near ``offset``: the exact one is
    # generally not a float32 number, so rounding it alone costs up to half an
    # ulp of ``offset``; one ulp (plus the local error) is the honest bound.
    for seed in range(4):
        scene = helpers.random_scene(
            seed, 9, 5, np.float32, masked=True, offset=offset, scale=FAR_SCALE
        )
        query.check(scene, scale=query.far_scale, offset=offset)
