# SPDX-License-Identifier: Apache-2.0
"""``held_signals``: SIGINT, SIGTERM and SIGHUP held back over a few steps that must not be cut
in two (creating a temporary folder and entering the ``try`` that removes it; removing it; starting
or closing a Dask cluster), then acted on. Python runs a signal's handler between any two
bytecodes, so without this a signal there leaves the folder (or the cluster's processes) behind
(issue 27.2: 1 of 300 sends left a POV-Ray folder)."""

from __future__ import annotations

from contextlib import contextmanager

__all__ = ["held_signals"]


@contextmanager
def held_signals(*, block_thread: bool = False):
    """Record SIGINT, SIGTERM and SIGHUP inside the block; as it ends, act on the first that came:
    KeyboardInterrupt for SIGINT, else the handler that was in place (the CLI's raises
    ``Terminated``), else the signal's own action. A signal recorded inside a block that raises
    is dropped for that exception (which is already ending the work).

    ``block_thread``: also block them in this thread, so that the threads and processes created
    inside the block start with them blocked (a process inherits the mask of the thread that
    starts it: Dask's loop thread and workers). Recording is still needed for this process,
    since a signal goes to any thread that does not block it (USD's and OpenImageIO's pools).

    Outside the main thread (which alone runs Python's handlers) the block runs as it is."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    caught: list[int] = []
    previous = {signum: signal.signal(signum, lambda signum, frame: caught.append(signum)) for signum in held}
    if block_thread:
        signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        if block_thread:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, held)  # one pending here is recorded now
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if caught:
        first = caught[0]
        if first == signal.SIGINT and previous[first] is signal.default_int_handler:
            raise KeyboardInterrupt
        if callable(previous[first]):
            previous[first](first, None)  # raises Terminated under the CLI
        elif previous[first] != signal.SIG_IGN:
            signal.raise_signal(first)  # its default action, as if it came now
