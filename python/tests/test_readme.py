"""The README's Python block runs as written (the quick examples of the book are the
command lines `.ci/check-docs` checks)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_readme_python_block_runs():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "the README has a Python block"
    for block in blocks:
        namespace = {}
        exec(compile(block, "README.md", "exec"), namespace)
    # What the block promises.
    assert namespace["poses"].shape == (40, 3)
    assert namespace["batch"].shape == (1000, 40, 3)
    assert namespace["result"]["models"][0]["name"] == "slip-blr"
    assert namespace["tracker"].length > 0
