"""Stop requests (SIGINT, SIGTERM) as a flag the process polls, installed before any heavy import.

A suite executable calls `guarded_main("package.module")` from a module that imports nothing else:
the handlers are in place about 50 ms after exec, before rclpy, NumPy or OpenCV load. A stop that
arrives while those imports run (they are most of a node's start-up, seconds on a loaded machine)
ends the process at once with exit code 0: nothing has started that needs stopping, so it leaves
without the interpreter's shutdown, which could wait forever on what the interrupted import left
half done (seen: a finalizer blocking in the final garbage collection). From then on
a stop only sets the flag, and the node ends through its normal, ordered path instead of a
KeyboardInterrupt raised wherever the main thread happens to be. (Before the handlers exist the
interpreter's defaults apply, as for any process.)

This module imports only the standard library and no rclpy: the signal handling stays ours, so a
node can stop its threads before its publishers and the ROS context go away.

A batch tool (a benchmark, a study) has no threads or nodes to stop in order while it computes:
inside `interruptible()` a stop raises KeyboardInterrupt where the main thread is, as Python's own
handler would, and `guarded_main(..., batch=True)` turns that into exit code 130 with one line.
"""

from __future__ import annotations

import contextlib
import faulthandler
import importlib
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# A process that does not stop when asked gets this first: every thread's Python stack goes to
# stderr (the node's log), so the log says where it hung before it is killed.
STACK_DUMP_SIGNAL = signal.SIGUSR1

_requested = threading.Event()
_received: list[str] = []
_exit_at_once = False  # while guarded_main imports the node: nothing to stop yet
_raise_at_once = False  # inside interruptible(): plain computation, nothing to stop in order
INTERRUPTED_EXIT_CODE = 130  # a batch tool stopped by a signal, as a shell reports Ctrl-C


def _on_signal(signum: int, _frame: FrameType | None) -> None:
    _received.append(signal.Signals(signum).name)
    _requested.set()
    if _exit_at_once:
        os._exit(0)
    if _raise_at_once:
        raise KeyboardInterrupt(_received[-1])


def install() -> None:
    """Catch SIGINT and SIGTERM from now on, and dump stacks on SIGUSR1 (main thread only;
    idempotent)."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, _on_signal)
    faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True)


def requested() -> bool:
    """Whether a stop signal has arrived."""
    return _requested.is_set()


def received() -> str | None:
    """The name of the first stop signal received ("SIGINT", "SIGTERM"), or None."""
    return _received[0] if _received else None


def wait(timeout: float | None = None) -> bool:
    """Block until a stop signal arrives or `timeout` s pass; True if one arrived."""
    return _requested.wait(timeout)


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Inside, a stop signal raises KeyboardInterrupt in the main thread at once (one that
    arrived before raises on entry); outside, stops are a flag again."""
    global _raise_at_once
    if requested():
        raise KeyboardInterrupt(received())
    previous, _raise_at_once = _raise_at_once, True
    try:
        yield
    finally:
        _raise_at_once = previous


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Inside `interruptible()`, a part that stops in order itself (a graph run: its nodes, its
    bag): stops are a flag again, and one that arrived raises KeyboardInterrupt on leaving."""
    global _raise_at_once
    previous, _raise_at_once = _raise_at_once, False
    try:
        yield
    finally:
        _raise_at_once = previous
        if previous and requested():
            raise KeyboardInterrupt(received())


def guarded_main(module: str, function: str = "main", batch: bool = False) -> int:
    """Install the handlers, then import `module` and return `module.function()`.

    The import (rclpy, OpenCV...) is most of a node's start-up; a stop requested during it ends
    the process with 0 at once (`os._exit`: no exception the import could turn into another, no
    shutdown that could hang on its half-done state). A `batch` tool's function runs
    `interruptible()`: a stop ends it with one line and `INTERRUPTED_EXIT_CODE`.
    """
    global _exit_at_once
    install()
    _exit_at_once = True
    try:
        entry: Callable[[], int] = getattr(importlib.import_module(module), function)
    finally:
        _exit_at_once = False
    if not batch:
        return entry()
    try:
        with interruptible():
            return entry()
    except KeyboardInterrupt:
        print(f"interrupted by {received() or 'SIGINT'}", file=sys.stderr, flush=True)
        return INTERRUPTED_EXIT_CODE
