"""The README's examples and the docstrings' examples run as written."""
import doctest
import pathlib
import re

import nprl.lwr

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def test_the_readme_examples_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert len(blocks) >= 4
    for i, block in enumerate(blocks):
        exec(compile(block, f"{README.name} block {i}", "exec"), {})


def test_the_docstring_examples_run():
    result = doctest.testmod(nprl.lwr)
    assert result.attempted > 0 and result.failed == 0
