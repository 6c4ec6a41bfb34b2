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

MAX_CACHED_MODELS = 32
"""Most compiled models kept (a stage scene with the iCub is ~1 MB): every shipped scenario
and robot pair fits, with room for edited variants; older ones are removed."""


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


def _prune(folder: Path, keep: int) -> None:
    """Remove all but the ``keep`` most recently used ``.mjb`` files of ``folder``."""
    files = sorted(folder.glob("*.mjb"), key=lambda p: p.stat().st_mtime_ns, reverse=True)
    for stale in files[keep:]:
        stale.unlink(missing_ok=True)


def load_or_compile(key: str, compile_model: Callable[[], mujoco.MjModel]) -> mujoco.MjModel:
    """The compiled model cached under ``key``; compiled with ``compile_model`` and saved if absent.

    Either way the model returned is the one loaded from the saved binary, so a first run and
    a cached run use the same model bit for bit.

    Raises:
        FogsimError: A cached file cannot be loaded (the message names it).
    """
    path = model_cache_dir() / f"{key}.mjb"
    if path.exists():
        os.utime(path)  # marks it recently used for _prune
    else:
        model = compile_model()
        buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
        mujoco.mj_saveModel(model, None, buffer)
        write_atomic(path, lambda f: f.write(buffer.tobytes()))
        _prune(path.parent, MAX_CACHED_MODELS)
    try:
        return mujoco.MjModel.from_binary_path(str(path))
    except ValueError as exc:
        raise FogsimError(
            f"{path}: cached compiled model cannot be loaded ({exc}); delete it"
        ) from exc
