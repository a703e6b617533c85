# SPDX-License-Identifier: Apache-2.0
"""The command-line process around a command: its exit statuses, SIGTERM and SIGHUP raised as
``Terminated`` (so every ``finally`` runs before exit), and the imports a command needs made with
Ctrl-C held back (``preimport``)."""

from __future__ import annotations

import sys

# 0 success, 1 images differ (diff/compare), 2 bad scene or usage, 3 backend failure, 130 interrupted.
EXIT_OK, EXIT_DIFFERENT, EXIT_SCENE, EXIT_BACKEND, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class Terminated(BaseException):
    """SIGTERM or SIGHUP arrived: raised in the main thread, like KeyboardInterrupt for SIGINT, so
    that every ``finally`` runs (POV-Ray is killed, its temporary folder removed) before exit.
    A BaseException, so that no ``except Exception`` swallows it."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


# Signals that end phongscene with cleanup and exit status 128 + the signal number (the shell's
# convention for "killed by signal N", as 130 is for Ctrl-C); SIGINT stays KeyboardInterrupt.
TERMINATING_SIGNALS = ("SIGTERM", "SIGHUP")
# Modules whose import a command needs, imported before the command runs with Ctrl-C deferred:
# USD's Python bindings catch a KeyboardInterrupt raised while they import (Tf prints "Error
# occurred postprocessing module" and the import goes on half-done), so an early Ctrl-C was lost.
# Every pxr module the reader imports, not pxr.Usd alone: each one's import swallows a signal the
# same way (a signal sweep after pxr.Usd alone was held: 4 of 300 runs lost one in pxr.UsdGeom's).
# ~40 ms more than pxr.Usd alone where the scene is read in the sandbox's child, nothing otherwise.
# And the native extension, which the reader calls too (OpenSubdiv): a signal raised inside its
# module set-up (nanobind's enums) aborted the process (SIGABRT, 1 of 300 sends).
USD_MODULES = (
    "pxr.Usd",
    "pxr.UsdGeom",
    "pxr.UsdLux",
    "pxr.UsdShade",
    "pxr.UsdSkel",
    "pxr.UsdRender",
    "pxr.Sdr",
    "phongscene.backends.native",
)
PREIMPORTS = {
    "compare": ("OpenImageIO",),
    **dict.fromkeys(("diff", "info", "validate", "import", "compile"), (*USD_MODULES, "OpenImageIO")),
    # OpenImageIO's libraries (~32 MiB resident) only once the C++ scene is freed, for the write
    # (cli/render.py): imported first, they sat under the BVH build's peak (benchmarks/README.md).
    "render": USD_MODULES,
    "preview": (*USD_MODULES, "OpenImageIO"),
}


def _on_terminating_signal(signum, frame) -> None:
    import signal

    # Cleanup is under way: a second SIGTERM must not interrupt it half-done.
    for name in TERMINATING_SIGNALS:
        signal.signal(getattr(signal, name), signal.SIG_IGN)
    if _in_unraisablehook:  # raised here it would be dropped again: once the hook is done
        _deliver_later(signum)
        return
    raise Terminated(signum)


# sys.unraisablehook before install_signal_handlers put _deliver_again in (None: not installed),
# and whether _deliver_again is running.
_previous_unraisablehook = None
_in_unraisablehook = False
# How long after a dropped Terminated it is delivered again: long enough for the unraisable hook
# to have returned (microseconds), short against any cleanup.
REDELIVERY_DELAY_S = 0.001


def _deliver_later(signum: int) -> None:
    """The handler back for ``signum``, and the signal delivered again to the main thread, from
    another thread, after REDELIVERY_DELAY_S."""
    import _thread
    import signal
    import threading

    signal.signal(signum, _on_terminating_signal)
    timer = threading.Timer(REDELIVERY_DELAY_S, _thread.interrupt_main, (signum,))
    timer.daemon = True
    timer.start()


def _deliver_again(unraisable) -> None:
    """sys.unraisablehook while the handlers are installed. A signal can arrive while Python runs
    a weakref callback or a ``__del__``, where an exception cannot propagate: Python prints
    "Exception ignored in ..." and goes on. So ``Terminated`` was lost there, with the handlers
    already ignoring the signals: a SIGTERM to the group during a Dask frame render once landed in
    ``WeakSet._remove``, and the render ran to its end and exited 0. Here it is delivered again
    once this hook has returned (delivered at once, the handler would run inside the hook, where
    an exception is dropped too); anything else goes to the previous hook."""
    global _in_unraisablehook
    if isinstance(unraisable.exc_value, Terminated):
        _in_unraisablehook = True
        try:
            _deliver_later(unraisable.exc_value.signum)
        finally:
            _in_unraisablehook = False
        return
    (_previous_unraisablehook or sys.__unraisablehook__)(unraisable)


def install_signal_handlers() -> dict:
    """Handle TERMINATING_SIGNALS (and a ``Terminated`` Python would drop: _deliver_again);
    returns the previous handlers for ``restore_signal_handlers`` (``main`` calls it, so calling
    this in-process, as the tests do, leaves the caller's handlers as they were)."""
    global _previous_unraisablehook
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}  # main() called from a worker thread: Python allows handlers only in the main one
    if sys.unraisablehook is not _deliver_again:
        _previous_unraisablehook = sys.unraisablehook
        sys.unraisablehook = _deliver_again
    return {
        signum: signal.signal(signum, _on_terminating_signal)
        for signum in (getattr(signal, name) for name in TERMINATING_SIGNALS)
    }


def restore_signal_handlers(previous: dict) -> None:
    """Undo ``install_signal_handlers``: its previous handlers, and sys.unraisablehook."""
    global _previous_unraisablehook
    import signal

    for signum, handler in previous.items():
        signal.signal(signum, handler)
    if previous and sys.unraisablehook is _deliver_again:
        sys.unraisablehook = _previous_unraisablehook or sys.__unraisablehook__
        _previous_unraisablehook = None


def preimport(modules) -> None:
    """Import ``modules`` with SIGINT, SIGTERM and SIGHUP held back, then act on the first that
    came: KeyboardInterrupt for SIGINT, the handler that was in place for the others
    (``Terminated`` under ``main``). USD's bindings swallow whatever a handler raises inside
    their import (Tf: "Error occurred postprocessing module"), so a SIGTERM there was lost and the
    command ran on with half-registered types (a signal sweep of 300 sends: 15 such runs)."""
    import importlib

    from ..held_signals import held_signals

    with held_signals():
        for module in modules:
            try:
                importlib.import_module(module)
            except ImportError:
                pass  # a missing module is the command's to report, in its own words
