"""What a run's set-up builds, kept on disk by content: the next run loads it instead.

A simulated run spends its set-up on things that depend only on its inputs and on the code:
the robot's pinocchio model (the URDF parsed and the meshes loaded,
:func:`fogsim.robot.model.load_robot`), the planned walk
(:func:`fogsim.sim.route_cache.planned_route`), the compiled scene
(:mod:`fogsim.sim.model_cache`). Each is kept under a content key derived from everything it
is built from (:func:`content_key`; the code by :func:`source_digest`), so a changed input or
changed code gives another key and misses the cache; files are written atomically and a folder
keeps a bounded number of them, the least recently used removed first (:func:`prune`).
The folders live beside :func:`fogsim.robot.mjcf.cache_root` (``$FOGSIM_CACHE`` or
``~/.cache/fogsim``).
"""

from __future__ import annotations

import hashlib
import os
import pickle
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from typing import TypeVar

from fogsim.atomic import write_atomic
from fogsim.errors import FogsimError

T = TypeVar("T")


def content_key(parts: tuple[bytes, ...]) -> str:
    """Hex sha256 of ``parts``, each length-prefixed so no two tuples share a key."""
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()


def library_versions(*packages: str) -> bytes:
    """The installed versions of ``packages`` (distribution names), as bytes for a key.

    A key that includes them changes with an upgrade of any of the packages.
    """
    return " ".join(f"{package} {version(package)}" for package in packages).encode()


def source_digest(*folders: Path) -> bytes:
    """sha256 of every Python source under ``folders`` (paths and contents, in sorted order).

    A key that includes it changes with any edit of that code: the result cached before the
    edit is never read again (it is pruned in time).
    """
    digest = hashlib.sha256()
    for folder in folders:
        for path in sorted(folder.rglob("*.py")):
            digest.update(str(path.relative_to(folder)).encode())
            digest.update(path.read_bytes())
    return digest.digest()


def _mtime_ns(path: Path) -> int:
    """Last use of a cached file, 0 if another process removed it meanwhile."""
    try:
        return path.stat().st_mtime_ns
    except FileNotFoundError:
        return 0


def prune(folder: Path, pattern: str, keep: int) -> None:
    """Remove all but the ``keep`` most recently used files of ``folder`` matching ``pattern``."""
    files = sorted(folder.glob(pattern), key=_mtime_ns, reverse=True)
    for stale in files[keep:]:
        stale.unlink(missing_ok=True)


def load_or_build(
    path: Path,
    build: Callable[[], T],
    keep: int,
    usable: Callable[[T], bool] = lambda value: True,
) -> T:
    """The value pickled at ``path``; built with ``build`` and pickled there if absent.

    A value that is not ``usable`` (it names a file since removed, say) is built again and
    replaces the file. After writing, the folder keeps the ``keep`` most recently used files
    with ``path``'s suffix. The files are this user's own cache, written only by this function.

    Raises:
        FogsimError: A cached file cannot be read (the message names it).
    """
    try:
        os.utime(path)  # marks it recently used for prune
    except FileNotFoundError:  # not cached yet, or pruned by another process
        return _store(path, build(), keep)
    try:
        with path.open("rb") as file:
            value = pickle.load(file)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError) as exc:
        raise FogsimError(f"{path}: cached set-up cannot be read ({exc}); delete it") from exc
    return value if usable(value) else _store(path, build(), keep)


def _store(path: Path, value: T, keep: int) -> T:
    """Pickle ``value`` at ``path`` atomically, bound the folder, return ``value``."""
    write_atomic(path, lambda file: pickle.dump(value, file, protocol=pickle.HIGHEST_PROTOCOL))
    prune(path.parent, f"*{path.suffix}", keep)
    return value
