"""No contact lost without a word: a master facing away from its slaves, a radius of 0,
a penetration deeper than the radius, and a ``grow`` that cannot grow."""

import re
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from jaxcontact import (
    Pairs,
    Search,
    Surface,
    all_to_all,
    bucket_sort,
    check_overflow,
    resumable_scan,
    validate,
)
from tests.support.helpers import FLOAT

RADIUS = 0.05
# A floor from x = -1 to 2, at y = 0, of 6 segments.
ALONG = np.linspace(-1.0, 2.0, 7)
LEFT_TO_RIGHT = np.stack([np.arange(6), np.arange(1, 7)], -1)  # normals point down
RIGHT_TO_LEFT = LEFT_TO_RIGHT[::-1, ::-1]  # normals point up


def floor(segments) -> Surface:
    nodes = np.stack([ALONG, np.zeros_like(ALONG)], -1).astype(FLOAT)
    return Surface(jnp.asarray(nodes), jnp.asarray(segments))


def block(bottom: float, rows: int = 4) -> jnp.ndarray:
    """A body of 6 x ``rows`` nodes, 0.2 apart (more than the radius), its bottom row at
    ``bottom`` (negative: pressed into the floor)."""
    across, up = np.meshgrid(np.linspace(0.0, 1.0, 6), bottom + 0.2 * np.arange(rows))
    return jnp.asarray(np.stack([across.ravel(), up.ravel()], -1), FLOAT)


def silently(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return call()


REVERSED = "form an open chain whose normals face away from the slaves near it"


def test_a_floor_listed_left_to_right_under_a_body_warns_saying_how_to_fix_it():
    """The issue's trap: a node 4.4 cm above the floor gets gap -0.044 and is active."""
    wrong, right = floor(LEFT_TO_RIGHT), floor(RIGHT_TO_LEFT)
    above = block(0.044)
    assert float(all_to_all(above, wrong, radius=RADIUS).gap[0]) < 0  # what goes wrong
    fix = "reverse the order of its segments and each segment's node order"
    for call in (
        lambda: validate(above, wrong, radius=RADIUS),
        lambda: Search(radius=RADIUS).allocate(above, wrong),
        lambda: Search(radius=RADIUS, method="exhaustive").allocate(above, wrong),
    ):
        with pytest.warns(UserWarning, match=REVERSED) as caught:
            call()
        message = str(caught[0].message)
        assert "rows [0, 1, 2, 3, 4, ... (6 rows in all)]" in message and fix in message
    # Listed right to left, its normals point up, at the body: silent.
    silently(lambda: validate(above, right, radius=RADIUS))
    silently(lambda: Search(radius=RADIUS).allocate(above, right))
    # A batch warns when any scene's floor faces away.
    search = Search(radius=RADIUS)
    batch = Surface(jnp.stack([right.nodes] * 2), jnp.stack([right.segments, wrong.segments]))
    with pytest.warns(UserWarning, match=REVERSED):
        search.allocate(jnp.stack([above, above]), batch)
    both_right = batch._replace(segments=jnp.stack([right.segments] * 2))
    silently(lambda: search.allocate(jnp.stack([above, above]), both_right))


def test_legitimate_contact_scenes_do_not_warn():
    """Slaves in contact penetrate by less than the radius: they never count against the
    floor, even when they are all the slaves within the radius."""
    right = floor(RIGHT_TO_LEFT)
    pressed = block(-0.01)
    assert bool(all_to_all(pressed, right, radius=RADIUS).active[:6].all())
    silently(lambda: validate(pressed, right, radius=RADIUS))
    silently(lambda: validate(block(-0.01, rows=1), right, radius=RADIUS))  # one row, all in
    silently(lambda: validate(jnp.array([[0.5, -0.01]], FLOAT), right, radius=RADIUS))
    silently(lambda: Search(radius=RADIUS).allocate(pressed, right))
    # Beside the floor's free end the side is not decided: nothing counts.
    beside = jnp.array([[2.5, 0.01], [2.5, -0.3], [3.0, -0.5]], FLOAT)
    silently(lambda: validate(beside, right, radius=RADIUS))
    # Closed loops keep their own check; an open chain beside a loop is judged alone.
    loop = Surface(
        jnp.asarray([[0.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]], FLOAT),
        jnp.array([[0, 1], [1, 2], [2, 3], [3, 0]]),
    )
    both = Surface(
        jnp.concatenate([right.nodes, loop.nodes]),
        jnp.concatenate([right.segments, loop.segments + len(ALONG)]),
    )
    silently(lambda: validate(block(0.2, rows=3), both, radius=RADIUS))
    with pytest.warns(UserWarning, match=REVERSED):
        reversed_floor = both.segments.at[:6].set(LEFT_TO_RIGHT)
        validate(block(0.2, rows=3), both._replace(segments=reversed_floor))


def test_the_pair_rule_keeps_a_body_from_counting_against_its_own_outline():
    """Two bodies: a slave is judged against the segments it may meet only."""
    right = floor(RIGHT_TO_LEFT)
    # The floor's own body lies under it (behind its own segments, body 0); the block
    # (body 1) lies above.
    under = jnp.asarray(np.stack([np.linspace(-0.9, 1.9, 30), np.full(30, -0.3)], -1), FLOAT)
    x = jnp.concatenate([block(0.03), under])
    slave_body = jnp.concatenate([jnp.ones(24, jnp.int32), jnp.zeros(30, jnp.int32)])
    labelled = right._replace(body=jnp.zeros(6, jnp.int32))
    with pytest.warns(UserWarning, match=REVERSED):  # without the rule: 30 behind, 18 before
        validate(x, labelled, radius=RADIUS)
    pairs = Pairs(slave_body=slave_body)
    silently(lambda: validate(x, labelled, radius=RADIUS, pairs=pairs))
    silently(lambda: Search(radius=RADIUS).allocate(x, labelled, pairs=pairs))


def test_a_radius_of_0_is_refused_by_a_search_and_warned_of_by_validate():
    right = floor(RIGHT_TO_LEFT)
    pressed = block(-0.01)
    reason = "a penetrating slave lies |gap| from its segment"
    with pytest.raises(ValueError, match=re.escape("Search(radius=0) cannot serve")) as error:
        Search(radius=0.0).allocate(pressed, right)
    assert reason in str(error.value) and "above the deepest penetration" in str(error.value)
    with pytest.warns(UserWarning, match=re.escape(reason)):
        validate(pressed, right, radius=0.0)
    # What it warns of: no penetrating node is found at 0.
    assert not bool(all_to_all(pressed, right, radius=0.0).found.any())
    # The one-call detectors keep 0 (a slave exactly on the master is found).
    on = jnp.array([[0.5, 0.0]], FLOAT)
    assert bool(bucket_sort(on, right, radius=0.0).found[0])


def impact(search: Search, depth: float, *, mask=None):
    """Two steps of a node of ``block(-0.01)``'s bottom row: in contact, then ``depth``
    below the floor (or above it, ``depth`` negative); ``(lost, state)``."""
    right = floor(RIGHT_TO_LEFT)
    x = block(-0.01)
    state = search.allocate(x, right, mask=mask)

    def step(state, x):
        contact, state = search.closest(state, x, right, mask=mask)
        return state, contact.found

    moved = x.at[2, 1].set(-depth)
    state, _ = jax.lax.scan(jax.jit(step), state, jnp.stack([x, moved]))
    return int(state.lost), state


@pytest.mark.parametrize(
    "search",
    [
        Search(radius=RADIUS),
        Search(radius=RADIUS, skin=0.02, compact=True),
        Search(radius=RADIUS, method="exhaustive", track=True),
    ],
    ids=["n-rows", "compact-skin", "exhaustive-track"],
)
def test_a_penetration_deeper_than_the_radius_is_reported_a_separation_is_not(search):
    lost, state = impact(search, 3 * RADIUS)
    assert lost == 1
    with pytest.raises(RuntimeError, match=r"1 contact\(s\) were lost.*larger Search\(radius"):
        check_overflow({"run": state})
    # Within the radius it is still found: nothing lost.
    assert impact(search, 0.5 * RADIUS)[0] == 0
    # Leaving upwards past the radius is a separation.
    assert impact(search, -3 * RADIUS)[0] == 0
    assert check_overflow(impact(search, -3 * RADIUS)[1]) is None
    # A masked row may go anywhere.
    mask = jnp.ones(24, bool).at[2].set(False)
    assert impact(search, 3 * RADIUS, mask=mask)[0] == 0


def test_sliding_off_the_end_of_a_floor_is_no_loss():
    right = floor(RIGHT_TO_LEFT)
    search = Search(radius=RADIUS)
    x = jnp.array([[1.95, -0.01]], FLOAT)
    state = search.allocate(x, right)
    _, state = search.closest(state, x, right)
    _, state = search.closest(state, jnp.array([[2.2, -0.5]], FLOAT), right)
    assert int(state.lost) == 0


def test_a_loss_is_counted_across_a_regrowth_and_resumable_scan_warns():
    """``allocate(at_least=state)`` keeps the last active contacts, so a chunk run again
    after ``grow`` still sees the loss; ``resumable_scan`` warns and keeps the count."""
    right = floor(RIGHT_TO_LEFT)
    search = Search(radius=RADIUS)
    x = block(-0.01)
    depths = jnp.asarray([0.01, 0.01, 3 * RADIUS, 3 * RADIUS], FLOAT)

    def step(state, depth):
        contact, state = search.closest(state, x.at[2, 1].set(-depth), right)
        return state, contact.found[2]

    state = search.allocate(x, right)
    regrown = search.allocate(x, right, at_least=state)
    _, after = search.closest(state, x, right)
    kept = search.allocate(x, right, at_least=after)
    np.testing.assert_array_equal(kept.last_active, after.last_active)
    assert int((regrown.last_active >= 0).sum()) == 0 < int((kept.last_active >= 0).sum())
    with pytest.warns(UserWarning, match=r"chunk from step 2 lost 1 contact\(s\)"):
        final, found, _ = resumable_scan(step, state, depths, chunk=2, grow=lambda c, _: c)
    np.testing.assert_array_equal(found, [True, True, False, False])
    assert int(final.lost) == 1
    with pytest.raises(RuntimeError, match="were lost"):
        check_overflow(final)


def test_resumable_scan_says_when_grow_returned_no_larger_sizes():
    """A ``grow`` that measures where a falling body is (not yet touching) returns the same
    sizes: said at once, with what to do, rather than after 8 reruns."""
    right = floor(RIGHT_TO_LEFT)
    # Two slaves a block: the bottom row's 3 blocks outgrow the 1 measured up high.
    search = Search(radius=RADIUS, slack=1.0, block_size=2)
    high = block(1.0)
    with pytest.warns(UserWarning, match="hold no contact"):
        state = search.allocate(high, right)
    heights = jnp.linspace(1.0, -0.01, 8, dtype=FLOAT)
    calls = []

    def step(state, height):
        contact, state = search.closest(state, block(0.0).at[:, 1].add(height), right)
        return state, contact.found.sum()

    def where_it_is(state, _):
        calls.append(1)
        return search.allocate(high, right, at_least=state)

    message = "grow returned sizes no larger than those it overflowed with"
    with pytest.raises(RuntimeError, match=message) as error:
        resumable_scan(step, state, heights, chunk=4, grow=where_it_is)
    assert "chunk from step 4" in str(error.value)
    assert "velocity times the chunk" in str(error.value)
    assert len(calls) == 1

    def ahead(state, chunk_heights):  # at the heights the chunk reaches
        for height in np.asarray(chunk_heights):
            state = search.allocate(block(float(height)), right, at_least=state)
        return state

    final, counts, regrown = resumable_scan(step, state, heights, chunk=4, grow=ahead)
    assert regrown == [4] and not bool(final.overflow)
    expected = [int(all_to_all(block(float(h)), right, radius=RADIUS).found.sum()) for h in heights]
    np.testing.assert_array_equal(counts, expected)
    jaxcontact.check_overflow(final)
