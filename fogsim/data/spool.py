"""Arrays on disk for whole-run image stacks: memory bounded by a frame, not by the run.

A recording's depth images, stacked, are the one array that grows with the input (a bag of
10 000 VGA images is 12 GB of float32). :func:`spooled_array` gives an array of any size backed
by an *anonymous* temporary file: it is unlinked as soon as it is made, so nothing is left behind
whatever happens to the process (killed, out of disk), and its space is freed when the last view
of the array goes away. Pages are written back by the OS as needed, so resident memory stays
bounded by the page cache, not the array's size.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from numpy.typing import DTypeLike

from fogsim.errors import OutputError


def _reserve(fd: int, size: int) -> None:
    """Give the file ``size`` bytes of real disk space now.

    A sparse file would only fail when a page is written back, and a full disk then kills the
    process with SIGBUS instead of raising: ``posix_fallocate`` refuses up front with ENOSPC.
    Platforms without it (macOS) get a sparse file, as ``numpy.memmap`` itself makes.
    """
    if hasattr(os, "posix_fallocate"):
        os.posix_fallocate(fd, 0, size)
    else:
        os.ftruncate(fd, size)


def spooled_array(
    shape: tuple[int, ...], dtype: DTypeLike, folder: str | os.PathLike[str] | None = None
) -> np.memmap:
    """A zero-filled array of ``shape`` and ``dtype`` on an anonymous temporary file.

    Args:
        shape: Array shape; every side ≥ 1.
        dtype: Element type.
        folder: Folder for the temporary file (the output's folder keeps the data on the disk
            that receives the result; ``/tmp`` may be memory). None = the system's temp folder.

    Raises:
        OutputError: The temporary file cannot be made or sized (the message names the folder
            and the system's reason).
    """
    count = int(np.prod(shape, dtype=np.int64))
    if count <= 0:
        raise ValueError(f"a spooled array needs every side >= 1, got shape {shape}")
    size = count * np.dtype(dtype).itemsize
    where = Path(folder) if folder is not None else Path(tempfile.gettempdir())
    try:
        with tempfile.TemporaryFile(dir=where) as handle:
            _reserve(handle.fileno(), size)
            # The map keeps its own reference to the file: closing the handle frees nothing.
            return np.memmap(handle, dtype=dtype, mode="r+", shape=shape)
    except OSError as exc:
        raise OutputError(
            f"cannot spool {size / 1e6:.1f} MB of images to {where}: {exc.strerror or exc}"
        ) from exc
