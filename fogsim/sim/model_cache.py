"""Compiled MuJoCo models cached on disk by content (``$FOGSIM_CACHE/scenes`` or ~/.cache).

Building a scene through ``dm_control.mjcf`` serialises megabytes of MJCF (the robot's meshes
are inlined) and compiles them on every run; a compiled model saved with ``mj_saveModel``
loads in milliseconds. :func:`load_or_compile` keeps one ``<key>.mjb`` per content key: the
caller derives the key from everything the model is built from (:func:`content_key`), so a
changed input gives a new key and misses the cache. Files are written atomically; the folder
keeps at most :data:`MAX_CACHED_MODELS` files, the least recently used go first.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from fogsim.atomic import write_atomic
from fogsim.errors import FogsimError
from fogsim.robot.mjcf import cache_root

MAX_CACHED_MODELS = 16
"""Most compiled models kept, the least recently used removed first: the 9 shipped scenarios
with their robots fit, with room for edited variants. A scene with the iCub is ~10 MB (its
meshes), so the folder stays under ~170 MB."""


def model_cache_dir() -> Path:
    """Folder of the cached compiled models: ``scenes`` beside the robot model cache."""
    return cache_root().parent / "scenes"


def content_key(parts: tuple[bytes, ...]) -> str:
    """Hex sha256 of ``parts``, each length-prefixed so no two tuples share a key."""
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()


def _mtime_ns(path: Path) -> int:
    """Last use of a cached file, 0 if another process removed it meanwhile."""
    try:
        return path.stat().st_mtime_ns
    except FileNotFoundError:
        return 0


def _prune(folder: Path, keep: int) -> None:
    """Remove all but the ``keep`` most recently used ``.mjb`` files of ``folder``."""
    files = sorted(folder.glob("*.mjb"), key=_mtime_ns, reverse=True)
    for stale in files[keep:]:
        stale.unlink(missing_ok=True)


def _save(model: mujoco.MjModel, path: Path) -> None:
    """Write ``model`` as MuJoCo's binary model file, atomically, then bound the folder."""
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    write_atomic(path, lambda f: f.write(buffer.tobytes()))
    _prune(path.parent, MAX_CACHED_MODELS)


def load_or_compile(key: str, compile_model: Callable[[], mujoco.MjModel]) -> mujoco.MjModel:
    """The compiled model cached under ``key``; compiled with ``compile_model`` and saved if absent.

    Either way the model returned is the one loaded from the saved binary, so a first run and
    a cached run use the same model bit for bit.

    Raises:
        FogsimError: A cached file cannot be loaded (the message names it).
    """
    path = model_cache_dir() / f"{key}.mjb"
    try:
        os.utime(path)  # marks it recently used for _prune
    except FileNotFoundError:  # not cached yet, or pruned by another process
        _save(compile_model(), path)
    try:
        return mujoco.MjModel.from_binary_path(str(path))
    except ValueError as exc:
        raise FogsimError(
            f"{path}: cached compiled model cannot be loaded ({exc}); delete it"
        ) from exc
