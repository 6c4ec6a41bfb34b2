"""End the ``fogsim`` process without tearing the interpreter down.

After a command has done its work, Python's own exit frees every module and object one by one
and runs the libraries' native destructors (numba's LLVM, MuJoCo, OpenGL, OpenBLAS's threads):
0.45 s of a 7.9 s stage run on a quiet 2-core machine, and seconds when it is loaded, with
nothing left to save. :func:`exit_process` does what matters of that exit, in Python's order,
and then ends the process at once (``os._exit``):

1. waits for the threads that are not daemons, and runs ``threading``'s exit hooks
   (``concurrent.futures`` pools shut down there) — what ``Py_FinalizeEx`` does first;
2. runs the ``atexit`` handlers (``logging`` flushed and closed, ``multiprocessing`` children
   joined, finalizers registered with ``weakref.finalize`` such as the renderers' GL contexts,
   EGL terminated);
3. flushes standard output and standard error.

Files the command wrote are closed by then (the run folders are written whole and renamed
into place, :mod:`fogsim.run.run_folder`); what the operating system holds of them is written
out by it as after any exit. Only for the command-line entry point: a library caller's
interpreter is not its to end.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from typing import NoReturn


def exit_process(code: int) -> NoReturn:
    """End the process with exit status ``code`` after the exit work that matters (module doc).

    Args:
        code: The exit status (0-255).
    """
    # Python's own finalisation calls these two, in this order, before freeing the modules;
    # neither has a public name.
    threading._shutdown()  # type: ignore[attr-defined]
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    os._exit(code)
