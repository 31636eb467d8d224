"""A deadline that ends the process with a chosen exit code even while the interpreter is blocked.

A Python timer thread needs the interpreter lock to run, so a C call that blocks while holding it
(rclpy's node destruction waiting in the middleware: pybind11 keeps the lock) stalls that timer
too; the process then hangs until something outside kills it. A POSIX timer with SIGEV_THREAD
notification instead runs a C function on a thread of the C library when it expires: here libc's
`_exit(code)`, which needs nothing of Python. `faulthandler`'s watchdog (also a C thread) first
writes every thread's Python stack to stderr, so the log says where the process was stuck.

Linux only (glibc's timer_create); elsewhere the deadline falls back to a Python timer thread.
"""

from __future__ import annotations

import ctypes
import faulthandler
import functools
import os
import sys
import threading

STACKS_BEFORE_EXIT_S = 0.2  # the stacks are written this long before the exit

_CLOCK_MONOTONIC = 1
_SIGEV_THREAD = 2


class _SigEvent(ctypes.Structure):
    """Linux's `struct sigevent` (64 bytes) as used with SIGEV_THREAD."""

    _fields_ = [
        ("value", ctypes.c_void_p),  # union sigval: the argument the function is called with
        ("signo", ctypes.c_int),
        ("notify", ctypes.c_int),
        ("function", ctypes.c_void_p),  # void (*)(union sigval)
        ("attributes", ctypes.c_void_p),  # pthread_attr_t *, NULL for the defaults
        ("_reserved", ctypes.c_byte * 32),
    ]


class _TimeSpec(ctypes.Structure):
    _fields_ = [("seconds", ctypes.c_long), ("nanoseconds", ctypes.c_long)]


class _ITimerSpec(ctypes.Structure):
    _fields_ = [("interval", _TimeSpec), ("value", _TimeSpec)]


class ExitDeadline:
    """`_exit(code)` after `seconds` unless cancelled; the threads' stacks go to stderr just before.

    Use it around a step that may block in C: `deadline = ExitDeadline(1.8, code)`, the step,
    `deadline.cancel()`.
    """

    def __init__(self, seconds: float, code: int) -> None:
        self._timer_id: ctypes.c_void_p | None = None
        self._fallback: threading.Timer | None = None
        faulthandler.dump_traceback_later(max(0.01, seconds - STACKS_BEFORE_EXIT_S), exit=False)
        try:
            self._timer_id = _start_native_exit_timer(seconds, code)
        except (AttributeError, OSError):  # no timer_create in this C library
            self._fallback = threading.Timer(seconds, _exit_now, args=(code,))
            self._fallback.daemon = True
            self._fallback.start()

    def cancel(self) -> None:
        faulthandler.cancel_dump_traceback_later()
        if self._timer_id is not None:
            _libc().timer_delete(self._timer_id)
            self._timer_id = None
        if self._fallback is not None:
            self._fallback.cancel()


@functools.cache
def _libc() -> ctypes.CDLL:
    """The C library with the POSIX timer functions' signatures declared (AttributeError when
    it has none)."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.timer_create.argtypes = [ctypes.c_int, ctypes.POINTER(_SigEvent), ctypes.c_void_p]
    libc.timer_settime.argtypes = [
        ctypes.c_void_p,
        ctypes.c_int,
        ctypes.POINTER(_ITimerSpec),
        ctypes.c_void_p,
    ]
    libc.timer_delete.argtypes = [ctypes.c_void_p]
    return libc


def _start_native_exit_timer(seconds: float, code: int) -> ctypes.c_void_p:
    libc = _libc()
    event = _SigEvent(
        # _exit(int) reads the low 32 bits of the first integer argument, which is where the
        # union sigval is passed on Linux's 64-bit ABIs (x86-64, AArch64).
        value=code,
        notify=_SIGEV_THREAD,
        function=ctypes.cast(libc._exit, ctypes.c_void_p).value,
    )
    timer_id = ctypes.c_void_p()
    if libc.timer_create(_CLOCK_MONOTONIC, ctypes.byref(event), ctypes.byref(timer_id)) != 0:
        raise OSError(ctypes.get_errno(), "timer_create failed")
    whole = int(seconds)
    expiry = _ITimerSpec(value=_TimeSpec(whole, int((seconds - whole) * 1e9)))
    if libc.timer_settime(timer_id, 0, ctypes.byref(expiry), None) != 0:
        libc.timer_delete(timer_id)
        raise OSError(ctypes.get_errno(), "timer_settime failed")
    return timer_id


def _exit_now(code: int) -> None:
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
