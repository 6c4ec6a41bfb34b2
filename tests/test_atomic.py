import errno
import os
import stat
import subprocess

import pytest

from fogsim.atomic import (
    TEMPORARY,
    OutputError,
    is_stale,
    temporary_path,
    write_atomic,
    write_text_atomic,
)


def test_write_text_atomic_writes_content_with_umask_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        path = write_text_atomic(tmp_path / "sub" / "a.json", "{}\n")
    finally:
        os.umask(old)
    assert path.read_text() == "{}\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def test_failed_write_leaves_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "report.json"
    target.write_text("old")

    def broken(handle):
        handle.write(b"half")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError, match="disk on fire"):
        write_atomic(target, broken)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_a_write_failure_is_an_output_error_naming_the_file_and_leaves_nothing(tmp_path):
    target = tmp_path / "maps.npz"
    target.write_text("old")

    def disk_full(handle):
        handle.write(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(
        OutputError, match=rf"^cannot write {target}: No space left on device \(ENOSPC\)$"
    ):
        write_atomic(target, disk_full)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["maps.npz"]
    with pytest.raises(OutputError, match=f"{target} is a file, not a folder$"):
        write_text_atomic(target / "below.json", "{}")


def test_temporaries_name_their_owner_and_stale_ones_are_removed(tmp_path):
    target = tmp_path / "report.json"
    mine = temporary_path(target)
    assert TEMPORARY.fullmatch(mine.name) and f"-{os.getpid()}-" in mine.name
    assert not is_stale(mine.name)  # this process is alive
    process = subprocess.Popen(["true"])
    process.wait()
    dead = tmp_path / mine.name.replace(f"-{os.getpid()}-", f"-{process.pid}-")
    dead.write_text("half")
    assert is_stale(dead.name)
    assert not is_stale("report.json") and not is_stale(".report.json.abc.tmp")
    long_name = tmp_path / ("é" * 200)
    assert len(os.fsencode(temporary_path(long_name).name)) < 255
    write_text_atomic(target, "{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]
