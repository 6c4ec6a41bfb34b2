"""The README's library example runs as printed and maps the flat floor it builds."""

import contextlib
import io
import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def python_block_after(heading: str) -> str:
    text = README.read_text(encoding="utf-8")
    section = text[text.index(heading) :]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match is not None, f"no python block after {heading!r}"
    return match.group(1)


def test_the_mapper_library_example_runs_and_finds_the_floor_at_zero():
    code = python_block_after("## The mapper as a library")
    out = io.StringIO()
    namespace: dict = {}
    with contextlib.redirect_stdout(out):
        exec(compile(code, str(README), "exec"), namespace)
    floor = namespace["types"] == namespace["CellType"].FLOOR
    assert floor.sum() > 1000  # the floor in view, 4 cm cells
    assert abs(float(namespace["np"].median(namespace["heights"][floor]))) < 1e-3
    assert "floor cells, median height 0.0000 m" in out.getvalue()
