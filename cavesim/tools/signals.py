"""Stopping signals as one interruption, for the long commands that leave a report however
they end: Ctrl-C's SIGINT, SIGTERM (`kill`, a service manager's stop) and SIGHUP (a closed
terminal or SSH session).

`stop_signals()` installs the handlers; `cavesim`'s main does it first thing, before its
imports. A signal raises `Interrupted` (a KeyboardInterrupt naming the signal) where the
program is, so that the caller's one path for an interruption serves all three. Within a
`held()` block a signal waits and is raised as the block ends: a stop that must not be cut
off halfway (ending child processes, writing the last report) holds them, and so does a
command's start until it can write a report saying how it ended (`hold_start`, let go by
`release_start`).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Interrupted(KeyboardInterrupt):
    """A stopping signal came: `signal` names it (e.g. "SIGTERM")."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.signal = name


def signal_of(interruption: KeyboardInterrupt) -> str:
    """The signal that raised `interruption` (a KeyboardInterrupt of Python's own Ctrl-C
    handler: SIGINT)."""
    return interruption.signal if isinstance(interruption, Interrupted) else "SIGINT"


class _Holds:
    """How deep the held blocks are nested, and the first signal that came in them."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.depth = 0
        self.pending: str | None = None
        self.start = False  # the start's hold is on

    def arrived(self, number: int, frame) -> None:
        name = signal.Signals(number).name
        if self.depth:
            self.pending = self.pending or name
            return
        raise Interrupted(name)

    # a signal interrupts the main thread alone: the other threads hold nothing
    def enter(self) -> None:
        if _in_main_thread():
            self.depth += 1

    def leave(self) -> None:
        if not _in_main_thread():
            return
        self.depth -= 1
        if not self.depth and self.pending is not None:
            name, self.pending = self.pending, None
            raise Interrupted(name)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


_holds = _Holds()


@contextmanager
def stop_signals() -> Iterator[None]:
    """Within the block, SIGINT, SIGTERM and SIGHUP raise `Interrupted` (or wait, in a
    held block); the handlers before it come back at its end, and a signal still held then
    is dropped (the command has ended anyway). Only the main thread handles signals: in
    another (a command run by a test's thread) the block changes nothing."""
    if not _in_main_thread():
        yield
        return
    previous = {number: signal.signal(number, _holds.arrived) for number in STOP_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        _holds.reset()


@contextmanager
def held() -> Iterator[None]:
    """Within the block a stopping signal waits; it is raised as the block ends."""
    _holds.enter()
    try:
        yield
    finally:
        _holds.leave()


def hold_start() -> None:
    """Hold stopping signals until `release_start`: a command's start, before it can write
    a report that says how it ended."""
    if not _holds.start and _in_main_thread():
        _holds.start = True
        _holds.enter()


def release_start() -> None:
    """End the start's hold (nothing when there is none): a signal that came meanwhile is
    raised here."""
    if _holds.start and _in_main_thread():
        _holds.start = False
        _holds.leave()
