"""``manifest.json``: what a run folder holds, written last, so a folder with one is complete.

A run (``fogsim run``, a seed of ``--seeds``, a suite scenario) and the folders of
``fogsim run --seeds`` and ``fogsim suite`` are written into a temporary folder that is renamed
into place at the end (:mod:`fogsim.run.run_folder`); the manifest is its last file. It names
the run (a random id), what ran (scenario, seed, seeds) and every file below the folder with its
size and SHA-256, so a folder can be checked against it: nothing missing, nothing changed,
nothing of another run beside it.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from fogsim.eval.report.io import load_json, write_json

MANIFEST_NAME = "manifest.json"
"""The manifest's file name in a run folder."""

Kind = Literal["run", "seeds", "suite"]
"""What wrote a folder: one run, ``fogsim run --seeds`` or ``fogsim suite``."""


@dataclass(frozen=True)
class ManifestFile:
    """One file of a run folder.

    Attributes:
        path: Its path relative to the folder, ``/``-separated (``seed_2/report.json``).
        size_bytes: Its size [bytes].
        sha256: SHA-256 of its content, hexadecimal.
    """

    path: str
    size_bytes: int
    sha256: str


@dataclass(frozen=True)
class Manifest:
    """``manifest.json`` of a run folder.

    Attributes:
        format: Always ``fogsim-manifest``.
        version: Schema version, 1.
        run_id: A random id of the run that wrote the folder (32 hexadecimal digits).
        kind: ``run``, ``seeds`` or ``suite``.
        scenario: The scenario's name (None: a suite, or a recording of real data).
        seed: The run's seed (None for ``seeds`` and ``suite`` folders and real data).
        seeds: The seeds of a ``seeds`` or ``suite --seeds`` folder (canonical spec, ``"1-8"``).
        files: Every file below the folder except the manifest, sorted by path.
    """

    format: Literal["fogsim-manifest"]
    version: Literal[1]
    run_id: str
    kind: Kind
    scenario: str | None
    seed: int | None
    seeds: str | None
    files: tuple[ManifestFile, ...]


def file_entries(folder: str | os.PathLike[str]) -> tuple[ManifestFile, ...]:
    """Every file below ``folder`` (symbolic links not followed) but its manifest, by path."""
    root = Path(folder)
    entries = []
    for directory, _, names in os.walk(root):
        for name in names:
            path = Path(directory) / name
            relative = path.relative_to(root).as_posix()
            if relative == MANIFEST_NAME:
                continue
            with path.open("rb") as handle:
                digest = hashlib.file_digest(handle, "sha256").hexdigest()
            entries.append(ManifestFile(relative, path.stat().st_size, digest))
    return tuple(sorted(entries, key=lambda entry: entry.path))


def write_manifest(folder: str | os.PathLike[str], manifest: Manifest) -> Path:
    """Write ``folder/manifest.json`` (atomically)."""
    return write_json(Path(folder) / MANIFEST_NAME, manifest)


def read_manifest(folder: str | os.PathLike[str]) -> Manifest:
    """Read ``folder/manifest.json``.

    Raises:
        ReportError: It is missing, not JSON, or does not match the schema (the message names
            the file and the key).
    """
    return load_json(Path(folder) / MANIFEST_NAME, Manifest, "manifest")
