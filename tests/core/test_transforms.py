"""Every public function: plain, under jit and under vmap; dtypes kept; no retracing."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcontact
from tests.support import helpers

DTYPES = pytest.mark.parametrize("dtype", helpers.FLOAT_DTYPES, ids=lambda d: np.dtype(d).name)
BATCH = 3


def contact_args(scene: helpers.Scene):
    return jnp.asarray(scene.x), helpers.surface_of(scene), jnp.asarray(scene.slave_mask)


def all_to_all(function, x, surface, mask, radius):
    return function(x, surface, radius=radius, mask=mask)


def swept(function, x, surface, mask, radius, x_prev):
    del radius
    return function(x_prev, x, surface, mask=mask)


# name -> (public function, how to call it, oracle, comparison)
FUNCTIONS = {
    "all_to_all": (
        jaxcontact.all_to_all,
        all_to_all,
        helpers.contact_oracle,
        helpers.assert_contact_matches,
    ),
    "swept": (jaxcontact.swept, swept, helpers.crossing_oracle, helpers.assert_crossing_matches),
}


def scene_args(name, scene: helpers.Scene):
    args = contact_args(scene) + (scene.radius,)
    return args + (jnp.asarray(scene.x_prev),) if name == "swept" else args


def run_plain(name, scenes):
    function, call = FUNCTIONS[name][:2]
    return [call(function, *scene_args(name, scene)) for scene in scenes]


def run_jit(name, scenes):
    function, call = FUNCTIONS[name][:2]
    jitted = jax.jit(function)
    return [call(jitted, *scene_args(name, scene)) for scene in scenes]


def run_vmap(name, scenes):
    # One batched call over BATCH scenes of equal shapes: slaves, nodes,
    # segments, both masks and the radius all carry the batch axis. The radii
    # are the widest float whatever the scenes' dtype (float64 with x64 on): a
    # float32 scene must stay float32.
    function, call = FUNCTIONS[name][:2]
    batched = [scene_args(name, scene) for scene in scenes]
    stacked = jax.tree.map(
        lambda *leaves: jnp.stack([jnp.asarray(leaf) for leaf in leaves]), *batched
    )
    radius = jnp.asarray(np.asarray([scene.radius for scene in scenes], np.float64))
    stacked = stacked[:3] + (radius,) + stacked[4:]
    # Jitted too: vmap's batching rules are what is under test, and eager
    # op-by-op dispatch of the batched program would only cost seconds.
    result = jax.jit(jax.vmap(lambda *args: call(function, *args)))(*stacked)
    return [jax.tree.map(lambda field, i=i: field[i], result) for i in range(len(scenes))]


TRANSFORMS = {"plain": run_plain, "jit": run_jit, "vmap": run_vmap}


def batch_of_scenes(dtype):
    scenes = [helpers.random_scene(seed, 9, 5, dtype, masked=True) for seed in range(BATCH)]
    # Distinct radii, so that a radius mixed up between batch members shows.
    return [
        scene._replace(radius=radius)
        for scene, radius in zip(scenes, [0.2, 0.3, 0.45], strict=True)
    ]


@DTYPES
@pytest.mark.parametrize("transform", list(TRANSFORMS))
@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_matches_oracle_plain_jitted_and_vmapped(name, transform, dtype):
    scenes = batch_of_scenes(dtype)
    oracle, compare = FUNCTIONS[name][2:]
    for scene, result in zip(scenes, TRANSFORMS[transform](name, scenes), strict=True):
        compare(result, oracle(scene), dtype)


@DTYPES
@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_every_public_function_keeps_the_input_dtype(name, dtype):
    # (A float64 radius with float32 slaves is covered by the vmap case above.)
    result = run_jit(name, batch_of_scenes(dtype)[:1])[0]
    expected = {"f": np.dtype(dtype), "i": np.dtype(np.int32), "b": np.dtype(bool)}
    for field, value in result._asdict().items():
        assert value.dtype == expected[value.dtype.kind], (field, value.dtype)
    floats = [field for field, value in result._asdict().items() if value.dtype.kind == "f"]
    assert floats == (["gap", "xi", "point", "normal"] if name == "all_to_all" else ["t", "point"])


@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_second_call_with_same_shapes_does_not_retrace(name):
    chex.clear_trace_counter()
    function, call = FUNCTIONS[name][:2]

    @jax.jit
    @chex.assert_max_traces(n=1)
    def run(*args):
        return call(function, *args)

    # Different coordinates, masks and radius, same shapes and dtypes.
    first, second = batch_of_scenes(helpers.FLOAT)[:2]
    run(*scene_args(name, first))
    run(*scene_args(name, second))
