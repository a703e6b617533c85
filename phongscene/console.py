# SPDX-License-Identifier: Apache-2.0
"""The ``phongscene`` process (the ``phongscene`` command, cli/launcher.c, and ``python -m
phongscene``): the CLI's
``main`` with two start-up and exit costs that a command-line run does not need (issue 15,
measured by benchmarks/startup.py):

- numpy's OpenBLAS starts a thread per core when numpy is imported (~40 ms CPU of a tiny render);
  phongscene's arrays are small for BLAS (3×3 and 4×4 transforms, the rest is not BLAS), so the
  process asks for one BLAS thread unless the user chose a count;
- the interpreter's teardown (freeing every module of numpy, pxr and OpenImageIO, ~35 ms CPU) is
  skipped once the command is done: exit handlers run and the standard streams are flushed, as at
  an ordinary exit, then the process ends. Only when no other thread is alive (one would be
  joined at an ordinary exit); otherwise, and on an exception, the exit is the ordinary one.

``phongscene.cli.main`` itself (what the tests and Python callers use) is unchanged.
"""

from __future__ import annotations

import os

# OpenBLAS reads the first of these that is set; a user's choice is kept.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def main() -> None:
    import signal

    # Until the CLI's own handlers are in place (they clean up temporary files and outputs),
    # nothing exists to clean up: a signal while the CLI imports ends the process at once with
    # its documented status and one line (issue 27.2), not a traceback from inside an import.
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, _exit_at_once)
    # The `phongscene` command (cli/launcher.c) starts the interpreter with these signals held
    # back, so that one sent during its start-up waits for the handlers above: let them in.
    signal.pthread_sigmask(signal.SIG_UNBLOCK, (signal.SIGINT, signal.SIGTERM, signal.SIGHUP))
    if not any(name in os.environ for name in BLAS_THREAD_VARIABLES):
        os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy is imported (the CLI imports it later)
    from .cli import main as cli_main
    from .cli.process import EXIT_INTERRUPTED

    try:
        # SIGINT is KeyboardInterrupt again (cli.main turns it into "interrupted", 130, after its
        # cleanup); cli.main replaces SIGTERM / SIGHUP's handlers with its own as it starts. One
        # raised before cli.main's own handling begins (its first lines import and install
        # handlers) or after it returned is reported here in the same words: inside this `try`
        # from the handler's first instant (a CI run once caught a Ctrl-C in cli.main's `import
        # threading`: a traceback and status -2).
        signal.signal(signal.SIGINT, signal.default_int_handler)
        code = cli_main()
        # The command is done and its status decided: a signal from now on is ignored rather than
        # kill the process by its default action while the interpreter shuts down (Python
        # restores SIG_DFL for its handlers as it finalizes; blocking would hold it in this
        # thread only).
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(signum, signal.SIG_IGN)
    except KeyboardInterrupt:
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(signum, signal.SIG_IGN)
        os.write(2, b"interrupted\n")
        code = EXIT_INTERRUPTED
    _exit_without_teardown(code)


def _exit_at_once(signum, frame) -> None:
    # The lines cli.main prints for the same signals; os.write: no buffered stream is half-written.
    line = b"interrupted\n" if signum == 2 else f"terminated by {_name(signum)}\n".encode()
    os.write(2, line)
    os._exit(128 + signum)


def _name(signum: int) -> str:
    import signal

    return signal.Signals(signum).name


def _exit_without_teardown(code: int) -> None:
    import atexit
    import sys
    import threading

    if threading.active_count() > 1:
        raise SystemExit(code)
    atexit._run_exitfuncs()  # what an ordinary exit runs first (weakref finalizers, logging)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except OSError:
        raise SystemExit(code) from None  # a closed pipe: reported as an ordinary exit reports it
    os._exit(code)
