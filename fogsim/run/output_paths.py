"""Output paths checked before any work: a run must not fail at its end because of where it writes.

:func:`check_output_path` finds, in a few milliseconds, what would make writing fail after a
long run: a path under a kernel pseudo-filesystem (``/proc``, ``/sys``, ``/dev``), a file where
a folder is needed (or the other way round), a file among the path's folders, a folder that
cannot be written (read-only file system, no permission: it creates and removes a temporary
there, which is the only test that holds for root too), too little free space. Every problem is
an :class:`~fogsim.atomic.OutputError` naming the argument, the path and what is allowed.

:func:`child_path` is the defence for paths made from data (a scenario's name in
``runs/<name>`` or the suite's ``OUT/<name>/``): the result must stay inside its parent.

The limits are named here, in one place: :data:`PSEUDO_FILESYSTEMS`, :data:`MIN_FREE_BYTES`,
:data:`NAME_MAX_BYTES`, :data:`PATH_MAX_BYTES`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

from fogsim.atomic import OutputError, make_temporary_folder, reason

PSEUDO_FILESYSTEMS = ("/proc", "/sys", "/dev")
"""Kernel pseudo-filesystems: process and system information and device files. Nothing can
be stored there (``/dev/null`` swallows it); a path below one is refused at once."""

MIN_FREE_BYTES = 100 * 2**20
"""Free space a run's disk needs before the run starts [bytes]: 100 MiB. The largest outputs
of the shipped scenarios are a few MiB (the stage's ``maps.npz`` and pictures, its recording
about 10 MiB; a ``--video`` some MiB more); 100 MiB leaves a margin of ten, and a disk with
less is full for practical purposes. A write that still finds the disk full fails with an
OutputError and leaves nothing."""

NAME_MAX_BYTES = 255
"""Longest file or folder name [bytes]: Linux's ``NAME_MAX`` on ext4, XFS, Btrfs and tmpfs."""

PATH_MAX_BYTES = 4096
"""Longest path [bytes]: Linux's ``PATH_MAX``."""

PathKind = Literal["folder", "file"]
"""What the path must be: a folder (``fogsim run --out``) or a file (``fogsim record --out``)."""


def resolve_output(path: str | os.PathLike[str], what: str) -> Path:
    """The absolute path with symbolic links resolved, refused under a pseudo-filesystem.

    Args:
        path: The path as given.
        what: The argument or role that names it in messages (``--out``).

    Raises:
        OutputError: A NUL character, a loop of symbolic links, a path below ``/proc``,
            ``/sys`` or ``/dev``, the root folder, a name or path too long for Linux.
    """
    text = os.fspath(path)
    if "\0" in text:
        raise OutputError(f"{what} {text!r}: contains a NUL character, which no path can hold")
    try:
        resolved = Path(text).resolve()
    except (OSError, RuntimeError) as exc:
        raise OutputError(f"{what} {text}: cannot be resolved: {exc}") from exc
    for root in PSEUDO_FILESYSTEMS:
        if resolved.is_relative_to(root):
            raise OutputError(
                f"{what} {text}: is under {root}, a kernel pseudo-filesystem that cannot store "
                "results; give a path on a disk, e.g. runs/NAME"
            )
    if resolved.parent == resolved:
        raise OutputError(f"{what} {text}: is the root folder; give a folder below it")
    long_name = next((p for p in resolved.parts if len(os.fsencode(p)) > NAME_MAX_BYTES), None)
    if long_name is not None:
        raise OutputError(
            f"{what} {text}: the name {long_name[:40]}... has {len(os.fsencode(long_name))} "
            f"bytes; a file or folder name may have at most {NAME_MAX_BYTES}"
        )
    if len(os.fsencode(resolved)) > PATH_MAX_BYTES:
        raise OutputError(
            f"{what} {text[:80]}...: the path has {len(os.fsencode(resolved))} bytes; at most "
            f"{PATH_MAX_BYTES} are allowed"
        )
    return resolved


def _nearest_existing(resolved: Path, what: str, text: str) -> Path:
    """The path itself or its nearest existing folder; refuses a file among its folders."""
    existing = resolved
    while not os.path.lexists(existing):
        existing = existing.parent
    if existing != resolved and not existing.is_dir():
        raise OutputError(
            f"{what} {text}: {existing} is a file, not a folder, so it cannot hold "
            f"{resolved.relative_to(existing)}"
        )
    return existing


def _check_kind(resolved: Path, kind: PathKind, what: str, text: str) -> None:
    """An existing path must be a folder (``folder``) or a regular file (``file``)."""
    if kind == "folder" and not resolved.is_dir():
        raise OutputError(
            f"{what} {text}: is a file, not a folder; a run writes report.json, maps.npz and "
            "pictures into a folder: give a new folder or an earlier result's"
        )
    if kind == "folder" and os.path.ismount(resolved):
        raise OutputError(
            f"{what} {text}: is a mount point, which a run cannot replace; give a folder in it"
        )
    if kind == "file" and resolved.is_dir():
        raise OutputError(f"{what} {text}: is a folder; give the file to write, e.g. {text}/x.npz")
    if kind == "file" and not resolved.is_file():
        raise OutputError(f"{what} {text}: is not a regular file (a device, socket or pipe)")


def _check_free(folder: Path, what: str, text: str) -> None:
    """The disk of ``folder`` has :data:`MIN_FREE_BYTES` and a free inode."""
    try:
        disk = os.statvfs(folder)
    except OSError as exc:
        raise OutputError(f"{what} {text}: cannot inspect {folder}: {reason(exc)}") from exc
    free_bytes = disk.f_bavail * disk.f_frsize
    if free_bytes < MIN_FREE_BYTES:
        raise OutputError(
            f"{what} {text}: only {free_bytes / 2**20:.1f} MiB free on the disk of {folder}; a "
            f"run needs at least {MIN_FREE_BYTES / 2**20:.0f} MiB: free space or choose another"
        )
    if disk.f_files > 0 and disk.f_favail == 0:
        raise OutputError(f"{what} {text}: the disk of {folder} has no free inode (file entry)")


def _check_writable(folder: Path, resolved: Path, what: str, text: str) -> None:
    """Create and remove an owned temporary folder in ``folder`` (what the run will do)."""
    try:
        make_temporary_folder(folder / resolved.name).rmdir()
    except OSError as exc:
        raise OutputError(f"{what} {text}: cannot write in {folder}: {reason(exc)}") from exc


def check_output_path(path: str | os.PathLike[str], kind: PathKind, what: str) -> Path:
    """Check, before any work, that a run can write ``path``; returns it resolved.

    Creates nothing (a probe temporary is created and removed in the nearest existing folder).

    Args:
        path: The output folder or file.
        kind: ``folder`` or ``file``.
        what: The argument or role naming it in messages (``--out``, ``--write-baseline``).

    Raises:
        OutputError: The path cannot be written; the message names ``what``, the path and why.
    """
    text = os.fspath(path)
    resolved = resolve_output(path, what)
    existing = _nearest_existing(resolved, what, text)
    if existing == resolved:
        _check_kind(resolved, kind, what, text)
        existing = resolved.parent
    _check_free(existing, what, text)
    _check_writable(existing, resolved, what, text)
    return resolved


def child_path(parent: str | os.PathLike[str], name: str, what: str) -> Path:
    """``parent / name`` for a name from data, checked to stay inside ``parent``.

    Args:
        parent: The folder that must hold the result.
        name: A name from data (a scenario's name).
        what: What the name is, for messages (``scenario name``).

    Raises:
        OutputError: The path, resolved, is not below ``parent`` (``..``, an absolute path, a
            symbolic link out of it) or the name holds a NUL character.
    """
    candidate = Path(parent) / name
    try:
        base = Path(parent).resolve()
        resolved = candidate.resolve()
    except (OSError, RuntimeError, ValueError) as exc:
        raise OutputError(f"{what} {name!r}: not a usable folder name: {exc}") from exc
    if resolved == base or not resolved.is_relative_to(base):
        raise OutputError(
            f"{what} {name!r}: {candidate} leads to {resolved}, outside {base}; a name must "
            "stay inside its folder (no '..', no absolute path, no link out of it)"
        )
    return candidate
