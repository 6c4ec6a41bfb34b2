"""Bounded reading of a NumPy ``.npz`` file: a zip archive of ``.npy`` members, one per array.

``numpy.load`` trusts the file: it reads a member whole, however large the size its zip
directory or its ``.npy`` header declares. :class:`NpzArchive` reads a member's ``.npy`` header
first (:class:`ArrayHeader`: shape, dtype, where the data start, checked against the size the zip
directory declares), lets the caller check it against its limits, and only then reads exactly
the declared bytes: a small array whole, a large one record by record (the frames of a
recording). Every failure is a :class:`~fogsim.errors.RecordingError` naming the file and the
array.
"""

from __future__ import annotations

import math
import tokenize
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import numpy as np
from numpy.lib import format as npy_format
from numpy.typing import NDArray

from fogsim.errors import RecordingError

ALLOWED_COMPRESSION = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
"""Zip compression methods a member may use: those ``numpy.savez`` and ``savez_compressed``
write (bzip2 and lzma would only add slower ways to inflate a small file)."""

_VERIFY_CHUNK_BYTES = 1 << 20
"""Bytes read at a time when a member is only checked (its CRC), never kept."""

_READ_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError)
"""What :mod:`zipfile` raises on a truncated, corrupt or unreadable archive."""

_HEADER_ERRORS = (ValueError, TypeError, SyntaxError, tokenize.TokenError, RecursionError)
"""What numpy's ``.npy`` header parser (``ast.literal_eval``, ``tokenize``, the dtype
constructor) raises on malformed header text."""


@dataclass(frozen=True)
class ArrayHeader:
    """What a member's ``.npy`` header declares.

    Attributes:
        key: The array's name (the member's name without ``.npy``).
        shape: Declared shape.
        dtype: Declared element type.
        fortran_order: The data are stored column-major.
        data_offset: Bytes from the member's start to its first data byte.
    """

    key: str
    shape: tuple[int, ...]
    dtype: np.dtype[Any]
    fortran_order: bool
    data_offset: int

    @property
    def nbytes(self) -> int:
        """Bytes of data the header declares."""
        return math.prod(self.shape) * self.dtype.itemsize


class NpzArchive:
    """An open ``.npz`` file whose members are read only after their headers were checked.

    Use as a context manager; :attr:`keys` are the array names (member names without ``.npy``).

    Raises:
        RecordingError: The file is not a readable zip archive or names a member twice.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        with self._failing("the archive", "is not a readable .npz (zip) file"):
            self._zip = zipfile.ZipFile(path)
        names = [info.filename for info in self._zip.infolist()]
        repeated = sorted({name for name in names if names.count(name) > 1})
        if repeated:
            self._zip.close()
            raise RecordingError(f"{path}: the archive holds members {repeated} more than once")
        self._infos = {info.filename.removesuffix(".npy"): info for info in self._zip.infolist()}

    def __enter__(self) -> NpzArchive:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._zip.close()

    @property
    def keys(self) -> tuple[str, ...]:
        """The array names, in the archive's order."""
        return tuple(self._infos)

    @contextmanager
    def _failing(self, what: str, doing: str) -> Iterator[None]:
        """Turn zip and I/O errors into a RecordingError naming the file and ``what``."""
        try:
            yield
        except RecordingError:
            raise
        except _READ_ERRORS as exc:
            raise RecordingError(f"{self.path}: {what} {doing}: {exc}") from exc

    def _open(self, key: str) -> IO[bytes]:
        """The member of ``key``, opened for reading (stored or deflated, not encrypted)."""
        info = self._infos[key]
        if info.flag_bits & 0x1:
            raise RecordingError(f"{self.path}: array '{key}' is encrypted; recordings are not")
        if info.compress_type not in ALLOWED_COMPRESSION:
            raise RecordingError(
                f"{self.path}: array '{key}' uses zip compression method {info.compress_type}; "
                f"allowed: {', '.join(ALLOWED_COMPRESSION.values())} (what numpy.savez writes)"
            )
        return self._zip.open(info)

    def header(self, key: str) -> ArrayHeader:
        """Read and check the ``.npy`` header of array ``key`` (no data are read).

        Raises:
            RecordingError: The header is malformed, declares an object array (which needs
                pickle) or a size the zip directory does not declare for the member.
        """
        with self._failing(f"array '{key}'", "cannot be read"), self._open(key) as member:
            version = npy_format.read_magic(member)
            readers = {
                (1, 0): npy_format.read_array_header_1_0,
                (2, 0): npy_format.read_array_header_2_0,
            }
            if version not in readers:
                raise RecordingError(
                    f"{self.path}: array '{key}' is in .npy format {version}; "
                    "allowed: 1.0 and 2.0 (what numpy.save writes)"
                )
            try:
                shape, fortran_order, dtype = readers[version](member)
            except _HEADER_ERRORS as exc:
                raise RecordingError(
                    f"{self.path}: array '{key}' has a malformed .npy header: {exc}"
                ) from exc
            header = ArrayHeader(key, tuple(shape), dtype, fortran_order, member.tell())
        if dtype.hasobject:
            raise RecordingError(
                f"{self.path}: array '{key}' holds Python objects ({dtype}), which only pickle "
                "can read; recordings hold numbers and text"
            )
        stored = self._infos[key].file_size - header.data_offset
        if any(n < 0 for n in header.shape) or header.nbytes != stored:
            raise RecordingError(
                f"{self.path}: array '{key}' declares shape {header.shape} of {dtype} "
                f"({header.nbytes} bytes) but its zip entry holds {stored} bytes of data"
            )
        return header

    def read(self, header: ArrayHeader) -> NDArray[Any]:
        """The whole array of a checked header (exactly ``header.nbytes`` are read)."""
        with (
            self._failing(f"array '{header.key}'", "cannot be read"),
            self._open(header.key) as member,
        ):
            member.seek(header.data_offset)
            data = self._read_exact(member, header.nbytes, header.key)
        order = "F" if header.fortran_order else "C"
        return np.frombuffer(data, dtype=header.dtype).reshape(header.shape, order=order)

    def records(self, header: ArrayHeader, start: int, stop: int) -> Iterator[bytes]:
        """The bytes of rows ``start`` to ``stop`` (excluded) of a C-ordered array, in order."""
        row_bytes = header.nbytes // header.shape[0] if header.shape[0] else 0
        with (
            self._failing(f"array '{header.key}'", "cannot be read"),
            self._open(header.key) as member,
        ):
            member.seek(header.data_offset + start * row_bytes)
            for row in range(start, stop):
                yield self._read_exact(member, row_bytes, f"{header.key}[{row}]")

    def verify(self, header: ArrayHeader) -> None:
        """Read the whole member without keeping it: its length and checksum must be right."""
        with self._failing(f"array '{header.key}'", "is corrupt"), self._open(header.key) as member:
            member.seek(header.data_offset)
            left = header.nbytes
            while left:
                chunk = min(left, _VERIFY_CHUNK_BYTES)
                left -= len(self._read_exact(member, chunk, header.key))

    def _read_exact(self, member: IO[bytes], size: int, what: str) -> bytes:
        """``size`` bytes of ``member``; a RecordingError if the member ends before."""
        data = member.read(size)
        if len(data) != size:
            raise RecordingError(f"{self.path}: array '{what}' is truncated")
        return data
