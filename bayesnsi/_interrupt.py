"""Deferral of Ctrl-C (SIGINT) across a block that must not be interrupted halfway."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

__all__ = ["interrupt_after"]


@contextmanager
def interrupt_after():
    """Hold a Ctrl-C (SIGINT) until the block ends, then raise KeyboardInterrupt.

    Used around an emcee run: emcee prints a traceback of any exception raised inside the
    log-probability function before re-raising it, so a Ctrl-C that lands there would spill a
    traceback on the user's terminal. A run takes about half a second at the default settings,
    so deferring the interrupt to its end costs nothing noticeable. Active only on the main
    thread, and only while Python's default handler is installed (a caller's own handler is
    left alone).

    Yields
    ------
    None

    Raises
    ------
    KeyboardInterrupt
        After the block, when a SIGINT arrived during it.
    """
    main_thread = threading.current_thread() is threading.main_thread()
    if not main_thread or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    received = []
    signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if received:
        raise KeyboardInterrupt
