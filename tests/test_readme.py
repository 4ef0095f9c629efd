"""The README's example runs as written."""

import pathlib
import re

import pytest

README = pathlib.Path(__file__).resolve().parent.parent / "README.md"


def test_readme_example_runs():
    # The README's scene (81,939 nodes) cut down to 2,000 so that every line
    # runs, gradient included, in seconds: the same programs at another size.
    text = README.read_text()
    (example,) = re.findall(r"## Example\n\n```python\n(.*?)```", text, flags=re.S)
    assert "cutting_scene(81_939," in example
    example = example.replace("cutting_scene(81_939,", "cutting_scene(2_000,")
    assert "curling_chip(10_000)" in example
    example = example.replace("curling_chip(10_000)", "curling_chip(2_000)")
    namespace: dict = {}
    exec(compile(example, str(README), "exec"), namespace)
    assert int(namespace["contact"].found.sum()) > 0
    assert int(namespace["own"].active.sum()) > 0
    assert namespace["grad"].shape == namespace["scene"].x.shape


def test_readme_batch_and_device_snippets_run():
    import jax
    import jax.numpy as jnp

    import jaxcontact
    from jaxcontact.scenes import cutting_scene

    section = README.read_text().split("### Batches and devices")[1].split("\n## ")[0]
    snippets = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert len(snippets) == 2
    scenes = [cutting_scene(600, tip) for tip in (15.0, 18.0)]
    public = [name for name in dir(jaxcontact) if not name.startswith("_")]
    namespace = {name: getattr(jaxcontact, name) for name in public}
    namespace.update(
        jax=jax,
        xs=jnp.stack([s.x for s in scenes]),
        surfaces=jax.tree.map(lambda *v: jnp.stack(v), *[s.surface for s in scenes]),
        x=scenes[1].x,
        surface=scenes[1].surface,
    )
    for snippet in snippets:
        exec(compile(snippet, str(README), "exec"), namespace)
    assert namespace["contacts"].gap.shape == (2, scenes[0].x.shape[0])
    assert not bool(namespace["contact"].overflow)
    assert namespace["on_tool"].shape == (2,)


def test_readme_bodies_snippet_runs():
    import jax.numpy as jnp

    import jaxcontact
    from jaxcontact.scenes import two_blocks

    section = README.read_text().split("### Bodies, self-contact and a radius per slave")[1]
    (snippet,) = re.findall(r"```python\n(.*?)```", section.split("\n### ")[0], flags=re.S)
    scene = two_blocks()
    reach = jnp.full(scene.x.shape[0], 0.8 * scene.radius, scene.x.dtype)
    namespace = {
        "jaxcontact": jaxcontact,
        "R": scene.radius,
        "x": scene.x,
        "surface": scene.surface,
        "nodes_of_slaves": scene.slave_node,
        "bodies": scene.slave_body,
        "reach": reach,
    }
    exec(compile(snippet, str(README), "exec"), namespace)
    contact = namespace["entries"].to_contact(scene.x.shape[0])
    assert int(contact.active.sum()) > 0


@pytest.mark.simulation
@pytest.mark.slow
def test_readme_simulation_snippet_runs():
    # The README's sizes (10,000 nodes, 0.5 mm of travel: 717 steps) cut down
    # so the snippet's every line still runs, gradient included, in seconds.
    section = README.read_text().split("## Simulation")[1].split("\n## ")[0]
    snippets = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    (snippet,) = [text for text in snippets if "ploughing(" in text]
    assert "ploughing(10_000, travel=0.5)" in snippet
    snippet = snippet.replace("ploughing(10_000, travel=0.5)", "ploughing(300, travel=0.1)")
    namespace: dict = {}
    exec(compile(snippet, str(README), "exec"), namespace)
    history, grads = namespace["history"], namespace["grads"]
    assert float(history.force[:, 0].mean()) > 0  # the tool pushes the workpiece in -x
    assert all(bool(abs(value) > 0) for value in (grads.rake, grads.stiffness))


def test_readme_cutting_snippet_runs():
    # The snippet as written, its last line's gradient taken as a value: the
    # same run's gradient is checked against finite differences in float64 by
    # tests/sim/test_cutting.py, and compiling it again in float32 here would
    # double CI's longest compile.
    section = README.read_text().split("### Orthogonal cutting")[1].split("\n### ")[0]
    (snippet,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    last = "print(jax.grad(force, argnums=(0, 1))(math.radians(5.0), 0.3))"
    assert last in snippet
    snippet = snippet.replace(last, "value = force(math.radians(5.0), 0.3)")
    namespace: dict = {}
    exec(compile(snippet, str(README), "exec"), namespace)
    assert 0 < float(namespace["value"]) < 1000  # N per mm: the tool pushes into the layer


def test_readme_friction_snippet_runs():
    import jax
    import jax.numpy as jnp

    import jaxcontact
    from jaxcontact.scenes import cutting_scene

    section = README.read_text().split("### Friction: slip history")[1]
    (snippet,) = re.findall(r"```python\n(.*?)```", section.split("\n### ")[0], flags=re.S)
    scene = cutting_scene(600, 18.0)
    # Three steps of the slaves sliding 0.01 along x under the tool.
    xs = jnp.stack([scene.x.at[:, 0].add(0.01 * k) for k in range(3)])
    namespace = {"jax": jax, "jaxcontact": jaxcontact, "x0": scene.x, "surface": scene.surface}
    namespace["xs"] = xs
    exec(compile(snippet, str(README), "exec"), namespace)
    assert namespace["on_slaves"].shape == xs.shape
    assert bool(jnp.isfinite(namespace["on_slaves"]).all())
    assert float(jnp.abs(namespace["on_slaves"]).sum()) > 0
    assert float(jnp.abs(namespace["friction"].traction).sum()) > 0  # it slid under friction
