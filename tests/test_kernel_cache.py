"""The mapper's kernels are cached under one stamp of all its kernel modules (`kernel_cache`)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from numba.core.dispatcher import Dispatcher

import mapper
from mapper import kernel_cache

REPO = Path(mapper.__file__).resolve().parent.parent


def _mapper_kernels() -> list[Dispatcher]:
    """Every cached numba kernel defined in a module of the mapper package."""
    import importlib
    import pkgutil

    kernels = []
    for info in pkgutil.walk_packages(mapper.__path__, "mapper."):
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if (
                isinstance(value, Dispatcher)
                and value.py_func.__module__ == info.name
                and value._cache.__class__.__name__ != "NullCache"
            ):
                kernels.append(value)
    return kernels


def test_every_mapper_kernel_is_stamped_by_the_whole_package():
    assert kernel_cache.INSTALLED
    kernels = _mapper_kernels()
    assert len(kernels) > 100
    stamp = kernel_cache.package_stamp()
    for kernel in kernels:
        locator = kernel._cache._impl._locator
        assert locator.__class__.__name__.startswith("Package"), kernel.py_func.__qualname__
        assert kernel._cache._cache_file._source_stamp == stamp


def test_the_stamp_changes_with_any_kernel_module_and_only_with_those(tmp_path):
    def stamp() -> str:
        return kernel_cache.package_stamp.__wrapped__(tmp_path)

    (tmp_path / "a.py").write_text("import numba\n")
    (tmp_path / "b.py").write_text("X = 1\n")
    (tmp_path / "__pycache__").mkdir()
    first = stamp()
    (tmp_path / "b.py").write_text("X = 2\n")  # no kernels: not stamped
    (tmp_path / "__pycache__" / "c.py").write_text("import numba\n")  # never a source
    assert stamp() == first
    os.utime(tmp_path / "a.py", (0, 0))  # the time alone: the same text
    assert stamp() == first
    (tmp_path / "a.py").write_text("import numba  # edited\n")
    edited = stamp()
    assert edited != first
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "d.py").write_text("import numba\n")  # a new kernel module
    assert stamp() != edited


_CALLER = """
import numba
from kpkg.callee import value

@numba.njit(cache=True)
def call():
    return value() + 1
"""
_CALLEE = """
import numba

@numba.njit(cache=True)
def value():
    return {value}
"""
_INIT = """
from pathlib import Path
{install}
"""
_MAIN = "from kpkg.caller import call; print(call())"


def _run(root: Path, env: dict[str, str]) -> int:
    output = subprocess.run(
        [sys.executable, "-c", _MAIN],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    return int(output.stdout.strip())


@pytest.mark.parametrize("installed", [True, False])
def test_an_edited_callee_reaches_a_cached_caller_in_another_module(tmp_path, installed):
    # The caller's module is unchanged; only the callee's file is edited between two runs.
    # numba's own stamp (the caller's file) serves the stale caller; the package stamp does not.
    package = tmp_path / "kpkg"
    package.mkdir()
    install = (
        "from mapper.kernel_cache import install\ninstall(Path(__file__).resolve().parent)"
        if installed
        else ""
    )
    (package / "__init__.py").write_text(textwrap.dedent(_INIT.format(install=install)))
    (package / "caller.py").write_text(_CALLER)
    (package / "callee.py").write_text(_CALLEE.format(value=10))
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(tmp_path), str(REPO)]),
        "NUMBA_CACHE_DIR": str(tmp_path / "numba_cache"),
    }
    assert _run(tmp_path, env) == 11
    (package / "callee.py").write_text(_CALLEE.format(value=20))
    assert _run(tmp_path, env) == (21 if installed else 11)
