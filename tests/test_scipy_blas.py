"""fogsim.run.scipy_blas: numba's BLAS and LAPACK set up without scipy.linalg's package."""

import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("scipy")


def _run(code: str) -> list[str]:
    """Run ``code`` in a fresh interpreter (its own sys.modules); its output's lines."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_blas_and_lapack_kernels_run_without_the_package_and_nothing_is_left_behind():
    out = _run(
        """
        import sys
        import numba
        import numpy as np
        from numba.core.registry import cpu_target
        from fogsim.run.scipy_blas import BLAS_MODULES, blas_modules_alone

        @numba.njit
        def largest(a):
            return np.linalg.eigvalsh(a)[-1]

        with blas_modules_alone():
            print(all(name in sys.modules for name in BLAS_MODULES))
            cpu_target.target_context.refresh()
            import numba.np.arraymath
            print(numba.np.arraymath._HAVE_BLAS)
            print(largest(np.diag([1.0, 3.0, 2.0])))
        print("scipy.linalg" in sys.modules, any(name in sys.modules for name in BLAS_MODULES))
        print(largest(np.diag([5.0, 4.0])))  # the routine's address kept: no import now
        print("scipy.linalg" in sys.modules)
        """
    )
    assert out == ["True", "True", "3.0", "False False", "5.0", "False"]


def test_after_the_block_scipy_linalg_imports_as_always():
    out = _run(
        """
        import sys
        import numba
        import numpy as np
        from numba.core.registry import cpu_target
        from fogsim.run.scipy_blas import blas_modules_alone

        with blas_modules_alone():
            cpu_target.target_context.refresh()

        @numba.njit
        def solve(a, b):
            return np.linalg.solve(a, b)  # another routine: numba imports its module now

        print(solve(2.0 * np.eye(3), np.array([1.0, 2.0, 4.0])).tolist())
        import scipy.linalg
        import scipy.linalg.cython_blas
        print(scipy.linalg.cython_blas is sys.modules["scipy.linalg.cython_blas"])
        print(scipy.linalg.solve(np.eye(2), np.array([3.0, 5.0])).tolist())
        """
    )
    assert out == ["[0.5, 1.0, 2.0]", "True", "[3.0, 5.0]"]


def test_a_module_that_fails_to_load_alone_leaves_the_ordinary_import():
    out = _run(
        """
        import importlib.util
        import sys

        def fail(spec):
            raise RuntimeError("an unexpected SciPy")

        importlib.util.module_from_spec = fail  # the loader's, not the import system's
        from numba.core.registry import cpu_target
        from fogsim.run.scipy_blas import BLAS_MODULES, blas_modules_alone

        with blas_modules_alone():
            print(any(name in sys.modules for name in BLAS_MODULES))
            cpu_target.target_context.refresh()
        print("scipy.linalg" in sys.modules)
        """
    )
    assert out == ["False", "True"]


def test_nothing_is_loaded_alone_when_the_package_is_already_imported():
    out = _run(
        """
        import scipy.linalg
        from fogsim.run import scipy_blas

        def refuse():
            raise AssertionError("loaded alone although scipy.linalg is imported")

        scipy_blas._load_alone = refuse
        with scipy_blas.blas_modules_alone():
            print("ordinary")
        """
    )
    assert out == ["ordinary"]


def test_the_warm_up_of_a_replay_imports_no_scipy_linalg():
    out = _run(
        """
        import sys
        from fogsim.config import resolve_params
        from fogsim.run.warmup import warm_up_kernels

        warm_up_kernels(resolve_params(None), None, simulated=False)
        print("scipy.linalg" in sys.modules)
        """
    )
    assert out == ["False"]
