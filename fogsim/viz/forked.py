"""A function called in a process forked ahead of the call: its answer or its exception sent back.

A run's pictures take matplotlib (about 0.5 s to import on a quiet 2-core machine) and then
about as long to draw, work nothing else in the run waits for. :class:`ForkedCall` forks at
once, lets the child get ready (``prepare``: the imports) while this process goes on, then calls
the function there with the arguments :meth:`ForkedCall.submit` sends (pickled);
:meth:`ForkedCall.result` waits for its return value and raises its exception here, with the
child's traceback as a note. Forked, the child has this process's modules and memory (nothing
imported twice, the function itself never pickled) and ends with ``os._exit``
(``multiprocessing``): it touches no OpenGL state it may have inherited. Fork it before the
caller starts threads (a forked child has only the thread that forked).

A child that is never sent its arguments ends when :meth:`ForkedCall.close` stops it or this
process ends (it checks its parent while it waits). Where there is no ``fork`` (Windows) there
is no child: ``prepare`` and the call run here, in :meth:`ForkedCall.submit`.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Generic, NoReturn, TypeVar

from fogsim.errors import FogsimError

T = TypeVar("T")

_PARENT_CHECK_S = 0.5
"""How often a child waiting for its arguments checks that its parent still runs [s]."""


class ForkedCall(Generic[T]):
    """One call of ``function`` in a child forked now; use once, and close (``with``).

    Unclosed, the child is waited for when the interpreter exits (it may fork in turn, so it
    is no daemon) and ends only when this process does.

    Args:
        function: What the child calls with :meth:`submit`'s arguments; its return value must
            pickle.
        prepare: Called by the child at once, before it waits for the arguments (imports).
        what: The child in messages (``"the picture process"``).
    """

    def __init__(
        self,
        function: Callable[..., T],
        *,
        prepare: Callable[[], object] | None = None,
        what: str = "the forked process",
    ) -> None:
        self._function = function
        self._prepare = prepare
        self.what = what
        self._submitted = False
        self._answer: tuple[T] | None = None  # the call made here (no fork)
        self._process: multiprocessing.process.BaseProcess | None = None
        if "fork" not in multiprocessing.get_all_start_methods():
            return
        context = multiprocessing.get_context("fork")
        self._connection, child_end = context.Pipe()
        parent_pid = os.getpid()
        self._process = context.Process(
            target=self._serve,
            args=(child_end, parent_pid),
            name=what.removeprefix("the ").replace(" ", "-"),
            daemon=False,  # a daemon may not fork (the picture process forks for Fig. 3)
        )
        self._process.start()
        child_end.close()

    def submit(self, *args: Any) -> None:
        """Send the arguments: the child calls ``function(*args)`` (here without ``fork``).

        Raises:
            FogsimError: Already submitted.
        """
        if self._submitted:
            raise FogsimError(f"{self.what}: submit() once")
        self._submitted = True
        if self._process is None:
            if self._prepare is not None:
                self._prepare()
            self._answer = (self._function(*args),)
            return
        self._connection.send(args)

    def result(self) -> T:
        """Wait for the call's return value; raises its exception (the child's traceback noted).

        Raises:
            FogsimError: Not submitted, or the child ended without an answer (its exit status
                named).
        """
        if not self._submitted:
            raise FogsimError(f"{self.what}: submit() before asking for the result")
        if self._process is None:
            assert self._answer is not None
            return self._answer[0]
        try:
            answer = self._connection.recv()
        except EOFError:
            self._process.join()
            raise FogsimError(
                f"{self.what} ended without a word (exit status {self._process.exitcode})"
            ) from None
        finally:
            self.close()
        if isinstance(answer, _ChildFailure):
            answer.reraise(self.what)
        return answer

    def close(self) -> None:
        """End the child and wait for it; idempotent.

        A child sent its arguments is waited for (it may be writing files: it ends before the
        caller cleans up); one that was not is stopped.
        """
        if self._process is None:
            return
        if not self._submitted and self._process.is_alive():
            self._process.terminate()
        self._connection.close()
        self._process.join()

    def __enter__(self) -> ForkedCall[T]:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ the child

    def _serve(self, connection: Connection, parent_pid: int) -> None:
        self._connection.close()  # else the child holds the parent's end open: no EOF
        failure: BaseException | None = None
        try:
            if self._prepare is not None:
                self._prepare()
        except BaseException as error:  # answered once the arguments come (the parent sends)
            failure = error
        while not connection.poll(_PARENT_CHECK_S):
            if os.getppid() != parent_pid:  # the parent ended without sending
                return
        try:
            args = connection.recv()
        except EOFError:  # the parent closed without sending
            return
        try:
            if failure is not None:
                raise failure
            answer: object = self._function(*args)
        except BaseException as error:
            answer = _ChildFailure.of(error)
        try:
            connection.send(answer)
        except OSError:  # the parent stopped listening (it failed meanwhile): nobody to tell
            return


@dataclass(frozen=True)
class _ChildFailure:
    """The child's exception (pickled) and its traceback as text, sent to the parent.

    Attributes:
        error: The pickled exception; one that does not pickle is sent as a RuntimeError
            with its type's name and its message.
        traceback: The child's traceback.
    """

    error: bytes
    traceback: str

    @classmethod
    def of(cls, error: BaseException) -> _ChildFailure:
        """``error`` as the child sends it."""
        text = "".join(traceback.format_exception(error))
        try:
            pickled = pickle.dumps(error)
            pickle.loads(pickled)
        except Exception:
            pickled = pickle.dumps(RuntimeError(f"{type(error).__name__}: {error}"))
        return cls(pickled, text)

    def reraise(self, where: str) -> NoReturn:
        """Raise the exception here, with the child's traceback as a note naming ``where``."""
        error = pickle.loads(self.error)
        error.add_note(f"in {where}:\n{self.traceback}")
        raise error
