"""Atomic file writes and the temporaries they leave when a process is killed.

A file is written into a temporary sibling and renamed into place, so it is either complete
or absent, never half written. Every temporary the testbed creates — these files, and the run
folders of :mod:`fogsim.run.run_folder` — is named after its owner process::

    .<target name>.fogsim-<host>-<pid>-<random>.tmp     (or ``.old``, optionally ``.tmp.mp4``)

A process killed with SIGKILL cannot remove its temporaries; the next atomic write or run into
the same folder removes those whose owner is gone (:func:`remove_stale_temporaries`). The
owner's host is part of the name because a process id means nothing on another machine that
shares the folder: temporaries of other hosts are never touched, nor those of a live process.

A failure to write (no space left, a read-only file system, no permission) is an
:class:`OutputError` naming the file and the system's reason; the temporary is removed first.
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import socket
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from fogsim.errors import OutputError

NAME_BYTES = 80
"""Bytes of the target's name kept in a temporary's name: a name may have 255 bytes, and the
owner tag (``.fogsim-<host>-<pid>-<random>.tmp.mp4``, at most 70 bytes) must still fit."""

HOST_CHARS = 24
"""Characters of the host name kept in the owner tag: enough to tell machines apart."""

PID_MAX = 2**22
"""Linux's largest possible process id (``PID_MAX_LIMIT``); a larger number in a name is not a
process of ours."""

TEMPORARY = re.compile(
    r"\..*\.fogsim-(?P<host>[A-Za-z0-9]+)-(?P<pid>[0-9]+)-[A-Za-z0-9_]+\.(?:tmp|old)"
    r"(?:\.[A-Za-z0-9]+)?",
    re.DOTALL,
)
"""The name of a temporary the testbed created (matched whole)."""


def _host() -> str:
    """This machine's name as the owner tag holds it (letters and digits)."""
    return re.sub(r"[^A-Za-z0-9]", "", socket.gethostname())[:HOST_CHARS] or "host"


def temporary_prefix(target: Path) -> str:
    """The start of a temporary's name for ``target``, owned by this process."""
    name = os.fsdecode(os.fsencode(target.name)[:NAME_BYTES])
    return f".{name}.fogsim-{_host()}-{os.getpid()}-"


def temporary_path(target: Path, kind: str = "tmp", suffix: str = "") -> Path:
    """A fresh owned temporary beside ``target`` (not created).

    Args:
        target: The file or folder the temporary stands for.
        kind: ``tmp`` (being written) or ``old`` (a replaced result being removed).
        suffix: Kept after the kind, for writers that choose a format by it (``.mp4``).
    """
    return target.parent / f"{temporary_prefix(target)}{secrets.token_hex(4)}.{kind}{suffix}"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def make_temporary_folder(target: Path) -> Path:
    """Create an owned temporary folder beside ``target``, with ``mkdir``'s permissions."""
    path = Path(tempfile.mkdtemp(prefix=temporary_prefix(target), suffix=".tmp", dir=target.parent))
    os.chmod(path, 0o777 & ~_umask())
    return path


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (one of another user counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def is_stale(name: str) -> bool:
    """Whether ``name`` is a temporary of this host whose owner process is gone."""
    match = TEMPORARY.fullmatch(name)
    if match is None or match["host"] != _host():
        return False
    pid = int(match["pid"])
    return 0 < pid <= PID_MAX and not _alive(pid)


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the temporaries in ``folder`` left by killed processes of this host.

    Never touches a live process's temporaries, another host's, or anything else.

    Returns:
        The removed paths.

    Raises:
        OutputError: A stale temporary cannot be removed.
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except FileNotFoundError:
        return removed
    for entry in entries:
        if not is_stale(entry.name):
            continue
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
        except FileNotFoundError:
            continue  # another process removed it first
        except OSError as exc:
            raise OutputError(
                f"cannot remove {entry.path}, left by a killed run: {reason(exc)}"
            ) from exc
        removed.append(Path(entry.path))
    return removed


def reason(exc: OSError) -> str:
    """The system's reason for an OSError, e.g. ``No space left on device (ENOSPC)``."""
    if exc.errno is None:
        return str(exc)
    return f"{os.strerror(exc.errno)} ({errno.errorcode.get(exc.errno, exc.errno)})"


def write_atomic(path: str | os.PathLike[str], writer: Callable[[IO[bytes]], None]) -> Path:
    """Write a file through ``writer`` into an owned temporary sibling, then rename it into place.

    The file gets the permissions a plain ``open(path, "w")`` would give it (0666 less umask).
    Stale temporaries of killed processes in the folder are removed first.

    Raises:
        OutputError: The folder or the file cannot be written (the message names the file and
            the system's reason: no space left, read-only file system, ...); nothing is left.
    """
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError as exc:  # mkdir says "File exists" of a file among the folders
        raise OutputError(f"cannot write {target}: {exc.filename} is a file, not a folder") from exc
    except OSError as exc:
        raise OutputError(f"cannot write {target}: {reason(exc)}") from exc
    try:
        remove_stale_temporaries(target.parent)
        fd, tmp_name = tempfile.mkstemp(
            prefix=temporary_prefix(target), suffix=".tmp", dir=target.parent
        )
    except OSError as exc:
        raise OutputError(f"cannot write {target}: {reason(exc)}") from exc
    try:
        with os.fdopen(fd, "wb") as handle:
            writer(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp_name, 0o666 & ~_umask())
        os.replace(tmp_name, target)
    except OSError as exc:
        Path(tmp_name).unlink(missing_ok=True)
        raise OutputError(f"cannot write {target}: {reason(exc)}") from exc
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return target


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` atomically (see :func:`write_atomic`)."""
    return write_atomic(path, lambda handle: handle.write(data))


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 text atomically (see :func:`write_atomic`)."""
    return write_bytes_atomic(path, text.encode("utf-8"))
