"""ForkedCall: one call in a process forked ahead of it, its answer or its exception sent back."""

from __future__ import annotations

import os
import time

import pytest

from fogsim.errors import FogsimError, OutputError
from fogsim.viz.forked import ForkedCall

_PREPARED: list[int] = []


def _prepare() -> None:
    _PREPARED.append(os.getpid())


def _answer(a: int, b: int) -> tuple[int, int, list[int]]:
    return a * b, os.getpid(), list(_PREPARED)


def test_the_call_runs_in_the_child_after_its_preparation_there():
    with ForkedCall(_answer, prepare=_prepare) as call:
        call.submit(6, 7)
        product, pid, prepared = call.result()
    assert product == 42
    assert pid != os.getpid()
    assert prepared == [pid]  # prepared in the child, before the call
    assert _PREPARED == []  # never here


def test_the_childs_exception_is_raised_here_with_its_traceback():
    def full_disk() -> None:
        raise OutputError("no space left for the picture")

    with ForkedCall(full_disk, what="the drawing process") as call:
        call.submit()
        with pytest.raises(OutputError, match="no space left") as raised:
            call.result()
    (note,) = raised.value.__notes__
    assert note.startswith("in the drawing process:") and "full_disk" in note


def test_a_failed_preparation_is_the_calls_error():
    def no_matplotlib() -> None:
        raise ModuleNotFoundError("No module named 'matplotlib'")

    with ForkedCall(_answer, prepare=no_matplotlib) as call:
        call.submit(1, 2)
        with pytest.raises(ModuleNotFoundError, match="matplotlib"):
            call.result()


def test_a_child_that_dies_is_an_error_naming_its_exit_status():
    with ForkedCall(lambda: os._exit(4)) as call:
        call.submit()
        with pytest.raises(FogsimError, match=r"ended without a word \(exit status 4\)"):
            call.result()


def test_a_child_never_sent_its_arguments_is_stopped_by_close():
    call = ForkedCall(_answer, prepare=lambda: time.sleep(30))
    process = call._process
    assert process is not None and process.is_alive()
    start = time.monotonic()
    call.close()
    assert not process.is_alive() and time.monotonic() - start < 10.0
    call.close()  # idempotent


def test_submit_once_and_result_after_submit():
    with ForkedCall(_answer) as call:
        with pytest.raises(FogsimError, match="submit"):
            call.result()
        call.submit(2, 3)
        with pytest.raises(FogsimError, match="once"):
            call.submit(2, 3)
        assert call.result()[0] == 6


def test_without_fork_the_call_is_made_here(monkeypatch):
    monkeypatch.setattr("multiprocessing.get_all_start_methods", lambda: ["spawn"])
    with ForkedCall(_answer, prepare=_prepare) as call:
        call.submit(3, 5)
        product, pid, prepared = call.result()
    _PREPARED.clear()
    assert (product, pid, prepared) == (15, os.getpid(), [os.getpid()])
