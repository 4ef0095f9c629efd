"""The README's example runs as written."""

import pathlib
import re

README = pathlib.Path(__file__).resolve().parent.parent / "README.md"


def test_readme_example_runs():
    text = README.read_text()
    (example,) = re.findall(r"## Example\n\n```python\n(.*?)```", text, flags=re.S)
    namespace: dict = {}
    exec(compile(example, str(README), "exec"), namespace)
    assert int(namespace["contact"].found.sum()) > 0
    assert namespace["grad"].shape == namespace["scene"].x.shape
