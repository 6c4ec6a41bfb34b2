"""numba's BLAS and LAPACK set up without importing ``scipy.linalg``'s package: 0.2 s a start.

A process's first compile or cache load makes numba load its registries
(``cpu_target.target_context.refresh()``), which imports ``numba.np.arraymath``, whose BLAS check
imports ``scipy.linalg.cython_blas``; the first call of a kernel that calls LAPACK
(`mapper.scanline.plane_pixels`' ``np.linalg.eigvalsh``) makes numba's C helpers import
``scipy.linalg.cython_lapack`` for the routine's address. Python imports a submodule's package
first, and ``scipy/linalg/__init__.py`` imports the whole of ``scipy.linalg``'s Python API:
0.18 s of CPU time on an idle AMD EPYC (numba 0.68.1, SciPy from dm_control's requirements),
paid by every run and replay for two modules of C function pointers.

:func:`blas_modules_alone` loads those two extension modules on their own (from their files,
under their full names: they import nothing of ``scipy.linalg``) and keeps them in
``sys.modules`` for a block — the warm-up (`fogsim.run.warmup.KernelWarmUp.finish`), which
loads numba's registries and calls every kernel once, so numba finds them there, keeps the
routines' addresses, and imports no package — then takes them out again: a later ``import
scipy.linalg`` (or a LAPACK routine the warm-up did not call) is Python's ordinary import, the
package and its submodules as always. Where SciPy is absent, ``scipy.linalg`` is already
imported, or loading the modules fails in any way, nothing is loaded and numba imports them
the ordinary way.
"""

from __future__ import annotations

import contextlib
import importlib.machinery
import importlib.util
import sys
from collections.abc import Iterator
from pathlib import Path

BLAS_MODULES = ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack")
"""The modules numba's BLAS and LAPACK checks import (``numba.np.linalg.ensure_blas``)."""


@contextlib.contextmanager
def blas_modules_alone() -> Iterator[None]:
    """The :data:`BLAS_MODULES` in ``sys.modules`` for the block, loaded without their package.

    Those it added are taken out when the block ends (module doc); nothing is added where
    ``scipy.linalg`` is already imported.
    """
    added = _load_alone() if "scipy.linalg" not in sys.modules else []
    try:
        yield
    finally:
        for name in added:
            sys.modules.pop(name, None)


def _load_alone() -> list[str]:
    """Load the :data:`BLAS_MODULES` from their files into ``sys.modules``; the names added.

    Nothing is added (an empty list) when any of them cannot be found or loaded.
    """
    scipy_spec = importlib.util.find_spec("scipy")
    if scipy_spec is None or scipy_spec.origin is None:
        return []
    folder = str(Path(scipy_spec.origin).parent / "linalg")
    modules = {}
    try:
        for name in BLAS_MODULES:
            if name in sys.modules:
                continue
            spec = importlib.machinery.PathFinder.find_spec(name.rpartition(".")[2], [folder])
            if spec is None or spec.loader is None:
                return []
            spec.name = name
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            modules[name] = module
    except Exception:  # an unexpected SciPy layout: the ordinary import, as before
        return []
    sys.modules.update(modules)
    return list(modules)
