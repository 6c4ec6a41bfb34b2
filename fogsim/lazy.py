"""A package's public names imported on first use (a module ``__getattr__``, PEP 562)."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_getattr(package: str, exports: Mapping[str, str]) -> Callable[[str], Any]:
    """The ``__getattr__`` of ``package`` that imports each exported name from its module.

    Args:
        package: The package's dotted name (for the error message).
        exports: Name → the module (dotted) that defines it.

    Returns:
        A module ``__getattr__``: the name's object, imported on first use.

    Raises:
        AttributeError: (from the returned function) the name is not exported.
    """

    def module_getattr(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module), name)

    return module_getattr
