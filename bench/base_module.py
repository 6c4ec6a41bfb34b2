"""A module of this repository as of another commit, imported beside this tree's (A/B benches)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def module_at(commit: str, module_path: str, directory: Path) -> ModuleType:
    """``module_path`` (e.g. ``mapper/occupancy.py``) as of ``commit``, as ``<stem>_base``.

    The source is written to ``directory`` (a temporary folder the caller owns), which goes on
    ``sys.path``: numba's cache finds a module's kernels by the module's name and file.

    Raises:
        subprocess.CalledProcessError: ``git show`` failed (no such commit or file).
    """
    source = subprocess.run(
        ["git", "show", f"{commit}:{module_path}"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    name = f"{Path(module_path).stem}_base"
    path = directory / f"{name}.py"
    path.write_text(source)
    sys.path.insert(0, str(directory))
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
