"""Compiled MuJoCo models cached on disk by content (``$FOGSIM_CACHE/scenes`` or ~/.cache).

Building a scene through ``dm_control.mjcf`` and compiling it takes about 0.1 s of CPU
(``stage`` with the iCub or ``talos_course`` with TALOS, median of 7, session 38,
``bench/bench_scene_compile.py``; 0.5 and 0.26 s while the meshes were MJCF text); a compiled
model saved with ``mj_saveModel`` loads in milliseconds. :func:`load_or_compile` keeps one
``<key>.mjb`` per content key: the caller derives the key from everything the model is built
from (:func:`fogsim.robot.disk_cache.content_key`), so a changed input gives a new key and
misses the cache. Files are written atomically; the folder keeps at most
:data:`MAX_CACHED_MODELS` files, the least recently used go first.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from fogsim.atomic import write_atomic
from fogsim.errors import FogsimError
from fogsim.robot.disk_cache import content_key, prune
from fogsim.robot.mjcf import cache_root

__all__ = ["MAX_CACHED_MODELS", "content_key", "load_or_compile", "model_cache_dir"]

MAX_CACHED_MODELS = 16
"""Most compiled models kept, the least recently used removed first: the 9 shipped scenarios
with their robots fit, with room for edited variants. A scene with the iCub is ~10 MB (its
meshes), so the folder stays under ~170 MB."""


def model_cache_dir() -> Path:
    """Folder of the cached compiled models: ``scenes`` beside the robot model cache."""
    return cache_root().parent / "scenes"


def _save(model: mujoco.MjModel, path: Path) -> None:
    """Write ``model`` as MuJoCo's binary model file, atomically, then bound the folder."""
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    write_atomic(path, lambda f: f.write(buffer.tobytes()))
    prune(path.parent, "*.mjb", MAX_CACHED_MODELS)


def load_or_compile(key: str, compile_model: Callable[[], mujoco.MjModel]) -> mujoco.MjModel:
    """The compiled model cached under ``key``; compiled with ``compile_model`` and saved if absent.

    Either way the model returned is the one loaded from the saved binary, so a first run and
    a cached run use the same model bit for bit.

    Raises:
        FogsimError: A cached file cannot be loaded (the message names it).
    """
    path = model_cache_dir() / f"{key}.mjb"
    try:
        os.utime(path)  # marks it recently used for prune
    except FileNotFoundError:  # not cached yet, or pruned by another process
        _save(compile_model(), path)
    try:
        return mujoco.MjModel.from_binary_path(str(path))
    except ValueError as exc:
        raise FogsimError(
            f"{path}: cached compiled model cannot be loaded ({exc}); delete it"
        ) from exc
