"""numba's cache of the mapper's kernels, stamped by the source of every kernel module.

numba (``cache=True``) keeps a kernel's compiled code with a stamp of the file that defines it
(a hash of its text) and throws the code away when that stamp changes. A kernel that calls
kernels of other files is compiled with their code inlined, and the stamp does not cover those
files: after an edit of ``mapper/scanline/rows.py`` the cached `mapper.scanline.fused.plane_labels`
still runs the old `split_rows` (numba 0.68.1: the edited kernel called on its own gave 0 row
segments, through the cached ``plane_labels`` 24), and every later run or replay measures the
old code without a word. ``plane_labels`` calls the kernels of five modules of
`mapper.scanline`, `mapper.tilt_kernels.plane_geometry` those of `mapper.scanline`.

:func:`install` puts locators in front of numba's own for the files of the `mapper` package:
the same cache folders as numba's (beside the sources, the user-wide folder, or
``NUMBA_CACHE_DIR``), but the stamp is one hash of every module of the package that uses numba
(:func:`package_stamp`), so an edit of any kernel module recompiles every kernel of the
package once, on the next run. Files outside the package keep numba's stamps. An installed
package does not change, so users only pay for the stamp (the package's kernel modules read
and hashed once a process: 10 ms).

`mapper` imports this module before any kernel module: the locator is chosen when a kernel is
decorated. If numba no longer has the private list of locator classes this relies on
(``numba.core.caching.CacheImpl._locator_classes``), nothing is installed and numba's own
per-file stamps apply.
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from numba.core import caching

PACKAGE_DIR = Path(__file__).resolve().parent
"""The `mapper` package's folder: the files whose kernels share one stamp."""

KERNEL_MARK = b"numba"
"""A module is a kernel module when its text mentions numba (imports it)."""


@functools.cache
def package_stamp(package_dir: Path = PACKAGE_DIR) -> str:
    """One stamp of every kernel module (``.py`` file mentioning numba) under ``package_dir``.

    A hex SHA-256 of the modules' relative paths and texts, in path order (``__pycache__``
    left out): it changes with any edit of any kernel module, and with one added, removed or
    renamed, not with a module without kernels, nor with a file's time alone. Computed once
    a process (the mapper's 40 modules: 10 ms): a file edited while a process runs counts
    from the next process on.
    """
    digest = hashlib.sha256()
    for path in sorted(package_dir.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        text = path.read_bytes()
        if KERNEL_MARK in text:
            digest.update(path.relative_to(package_dir).as_posix().encode())
            digest.update(b"\0")
            digest.update(text)
            digest.update(b"\0")
    return digest.hexdigest()


def package_locators(package_dir: Path) -> list[type]:
    """Numba cache locator classes for the files under ``package_dir`` (module docstring).

    One per numba locator with a source file behind it, in numba's order: the folder named by
    ``NUMBA_CACHE_DIR``, beside the sources, the user-wide folder. Each declines (``None``)
    files outside ``package_dir``, so numba's own locators take those.
    """
    root = str(package_dir.resolve())

    def inside(py_file: str) -> bool:
        return os.path.commonpath([root, os.path.abspath(py_file)]) == root

    def locator(base: type) -> type:
        def from_function(cls: type, py_func: Callable[..., Any], py_file: str) -> Any:
            if not inside(py_file):
                return None
            return super(cls, cls).from_function(py_func, py_file)

        def get_source_stamp(self: Any) -> str:
            return package_stamp(package_dir)

        return type(
            f"Package{base.__name__}",
            (base,),
            {
                "from_function": classmethod(from_function),
                "get_source_stamp": get_source_stamp,
                "__doc__": f"numba's {base.__name__} with one stamp for {root}.",
            },
        )

    return [
        locator(caching.UserProvidedCacheLocator),
        locator(caching.InTreeCacheLocator),
        locator(caching.UserWideCacheLocator),
    ]


def install(package_dir: Path = PACKAGE_DIR) -> bool:
    """Put :func:`package_locators` in front of numba's locators (once per package folder).

    Returns:
        Whether they are installed (False: numba has no such list; its own stamps apply).
    """
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if not isinstance(classes, list):
        return False
    root = str(package_dir.resolve())
    if any(getattr(cls, "_package_root", None) == root for cls in classes):
        return True
    new = package_locators(package_dir)
    for cls in new:
        cls._package_root = root  # type: ignore[attr-defined]
    classes[:0] = new
    return True


INSTALLED = install()
"""Whether the mapper's kernels are cached under the package-wide stamp."""
