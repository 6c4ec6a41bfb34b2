"""A run's results belong to that run: written into a temporary folder, renamed into place whole.

:class:`RunFolder` is how every run writes its folder (``fogsim run``, each seed of ``--seeds``,
each suite scenario, and the folders of ``--seeds`` and ``suite`` around them)::

    with RunFolder(out) as folder:          # checks `out`, creates `.out.fogsim-….tmp` beside it
        ... write into folder.path ...
        folder.commit("run", scenario=..., seed=...)   # manifest.json last, then rename

* Before any work the target is checked (:func:`fogsim.run.output_paths.check_output_path`)
  and must be new, empty, or a result a run wrote (:func:`foreign_file`): a run replaces its
  folder whole, so it never writes into a folder holding anything else.
* The results go into an owned temporary folder next to the target; ``manifest.json``
  (:mod:`fogsim.run.manifest`) is written last; the commit renames the older result away
  (``.old``), renames the new one into place and removes the old. Killed at any point, the
  target holds the older complete result or nothing, never a mix; the temporaries it leaves
  are owned by the dead process and removed by the next run into the same parent folder
  (:func:`fogsim.atomic.remove_stale_temporaries`; never those of a live run).
* An error (or Ctrl-C) removes the temporary folder and leaves the target as it was.
* Two runs into one target: commits into one parent folder take turns (an exclusive lock on
  the parent), so the later commit replaces the earlier result whole.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType

from fogsim.atomic import (
    TEMPORARY,
    OutputError,
    make_temporary_folder,
    reason,
    remove_stale_temporaries,
    temporary_path,
)
from fogsim.errors import ReportError
from fogsim.run.manifest import (
    MANIFEST_NAME,
    Kind,
    Manifest,
    file_entries,
    read_manifest,
    write_manifest,
)
from fogsim.run.output_paths import check_output_path

RESULT_FILE_NAMES = frozenset(
    {
        "report.json",
        "maps.npz",
        "frames.csv",
        "fog_map.png",
        "fig3_panels.png",
        "difference.png",
        "fig5_comparison.png",
        "run.mp4",
        "summary.json",
        "summary.md",
        MANIFEST_NAME,
    }
)
"""Files a run, ``--seeds`` or the suite writes: a folder of only these (in any subfolders) is
an earlier result even without a manifest (results written before manifests existed)."""


def _files(folder: Path) -> Iterator[str]:
    """Paths of the files below ``folder`` relative to it, ``/``-separated.

    A symbolic link (to a folder too) counts as a file and is not followed.
    """
    for directory, folders, names in os.walk(folder):
        links = [name for name in folders if Path(directory, name).is_symlink()]
        for name in [*names, *links]:
            yield (Path(directory) / name).relative_to(folder).as_posix()


def foreign_file(folder: Path) -> str | None:
    """The first file in ``folder`` that no run wrote (None: it may be replaced whole).

    With ``manifest.json`` the folder may hold only the manifest's files; without one (an
    earlier version's result) only files named as results (:data:`RESULT_FILE_NAMES`).
    Temporaries of the testbed count as a run's.

    Raises:
        OutputError: The folder's ``manifest.json`` is unreadable.
    """
    if (folder / MANIFEST_NAME).is_file():
        try:
            manifest = read_manifest(folder)
        except ReportError as exc:
            raise OutputError(f"{folder} holds a broken {MANIFEST_NAME}: {exc}") from exc
        allowed = {entry.path for entry in manifest.files} | {MANIFEST_NAME}
        return next((path for path in _files(folder) if path not in allowed), None)
    return next(
        (
            path
            for path in _files(folder)
            if Path(path).name not in RESULT_FILE_NAMES
            and TEMPORARY.fullmatch(Path(path).name) is None
        ),
        None,
    )


_UNCHANGED = "nothing was written (an earlier result there is unchanged)"
"""The end of the message of a run that failed to write (said once, by the innermost folder)."""


def check_run_folder(target: str | os.PathLike[str], what: str) -> Path:
    """Check, before any work, that a run may write the folder ``target``; returns it resolved.

    Args:
        target: The output folder.
        what: The argument or role naming it in messages (``--out``).

    Raises:
        OutputError: It cannot be written (:func:`fogsim.run.output_paths.check_output_path`)
            or holds a file no run wrote (:func:`foreign_file`).
    """
    resolved = check_output_path(target, "folder", what)
    if not resolved.parent.is_dir():
        return resolved  # nothing there yet
    # Under the parent's lock: another run's commit swaps the folder and its manifest together.
    with _locked(resolved.parent):
        _refuse_foreign(resolved, what)
    return resolved


def _refuse_foreign(target: Path, what: str) -> None:
    """Raise :class:`OutputError` if the folder ``target`` holds a file no run wrote."""
    foreign = foreign_file(target) if target.is_dir() else None
    if foreign is not None:
        raise OutputError(
            f"{what} {target}: holds {target / foreign}, which no run wrote; a run replaces its "
            "folder whole, so it writes only into a new or empty folder or over an earlier "
            f"result: choose another folder or move {target / foreign} away"
        )


@contextmanager
def _locked(folder: Path) -> Iterator[int]:
    """An exclusive lock on ``folder`` (held by this process until the block ends); its fd."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield fd
    finally:
        os.close(fd)


class RunFolder:
    """A run's output folder, written as a temporary sibling and renamed into place whole.

    Attributes:
        target: The output folder, resolved.
        path: The temporary folder to write into (valid inside the ``with`` block).
        run_id: The run's random id (32 hexadecimal digits), written to the manifest.
    """

    def __init__(self, target: str | os.PathLike[str], what: str = "output folder") -> None:
        """Check the target before any work.

        Args:
            target: The output folder.
            what: The argument or role naming it in messages (``--out``).

        Raises:
            OutputError: The target cannot be written or holds files no run wrote.
        """
        self.what = what
        self.target = check_run_folder(target, what)
        self.run_id = uuid.uuid4().hex
        self.path = self.target
        self._committed = False

    def __enter__(self) -> RunFolder:
        parent = self.target.parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            with _locked(parent):
                remove_stale_temporaries(parent)
                self.path = make_temporary_folder(self.target)
        except OSError as exc:
            raise OutputError(f"{self.what} {self.target}: cannot write: {reason(exc)}") from exc
        return self

    def commit(
        self,
        kind: Kind,
        *,
        scenario: str | None = None,
        seed: int | None = None,
        seeds: str | None = None,
    ) -> Manifest:
        """Write ``manifest.json`` last and rename the folder into place, replacing an older one.

        Args:
            kind: ``run``, ``seeds`` or ``suite``.
            scenario: The scenario's name (None for a suite or real data).
            seed: The run's seed (None for ``seeds``, ``suite`` and real data).
            seeds: The seeds of a ``seeds`` or ``suite --seeds`` folder.

        Raises:
            OutputError: The manifest or the rename fails, or the target got a file no run
                wrote while this run ran (the new result is then dropped).
        """
        files = file_entries(self.path)
        manifest = Manifest("fogsim-manifest", 1, self.run_id, kind, scenario, seed, seeds, files)
        write_manifest(self.path, manifest)
        parent = self.target.parent
        try:
            with _locked(parent) as parent_fd:
                _refuse_foreign(self.target, self.what)  # files may have come meanwhile
                old = None
                if os.path.lexists(self.target):
                    old = temporary_path(self.target, "old")
                    os.rename(self.target, old)
                os.rename(self.path, self.target)
                os.fsync(parent_fd)
                self._committed = True
        except OSError as exc:
            raise OutputError(f"{self.what} {self.target}: cannot write: {reason(exc)}") from exc
        self.path = self.target
        if old is not None:
            # Owned by this process: if it cannot be removed now, the next run removes it.
            shutil.rmtree(old, ignore_errors=True)
        return manifest

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if self._committed or self.path == self.target:
            return
        # A leftover is owned by this process: the next run into the parent removes it. The
        # error that brought us here matters more than one about removing it.
        shutil.rmtree(self.path, ignore_errors=True)
        if isinstance(exc, OSError):
            where = f" {exc.filename}" if exc.filename is not None else ""
            message = f"cannot write{where}: {reason(exc)}"
        elif isinstance(exc, OutputError):
            message = str(exc)
        else:
            return
        prefix = f"{self.what} {self.target}: "
        message = message if message.startswith(prefix) else prefix + message
        said = message.endswith(_UNCHANGED)  # by a run folder inside this one
        raise OutputError(message + ("" if said else f"; {_UNCHANGED}")) from exc
