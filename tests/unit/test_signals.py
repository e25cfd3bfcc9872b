"""Stopping signals as one interruption (cavesim/tools/signals.py): raised where the program
is, or, in a held block and during a command's start, when the hold ends. Each signal is
raised in this thread (`signal.raise_signal`), so it is handled before the next line."""

from __future__ import annotations

import signal
import threading

import pytest

from cavesim.tools.signals import (
    Interrupted,
    held,
    hold_start,
    release_start,
    signal_of,
    stop_signals,
)


def test_a_signal_interrupts_where_the_program_is_and_is_named():
    with stop_signals(), pytest.raises(Interrupted) as raised:
        signal.raise_signal(signal.SIGTERM)
    assert raised.value.signal == "SIGTERM" and signal_of(raised.value) == "SIGTERM"
    assert signal_of(KeyboardInterrupt()) == "SIGINT"  # Python's own Ctrl-C handler's


def test_a_held_block_goes_on_to_its_end_and_then_raises_the_first_signal():
    done = []
    with stop_signals(), pytest.raises(Interrupted) as raised:
        with held():
            signal.raise_signal(signal.SIGHUP)
            with held():  # nested: only the outer end raises
                signal.raise_signal(signal.SIGTERM)
            done.append("the stop it protects")
    assert done == ["the stop it protects"] and raised.value.signal == "SIGHUP"


def test_a_signal_while_a_command_starts_waits_until_it_can_be_reported():
    with stop_signals():
        hold_start()
        signal.raise_signal(signal.SIGINT)
        with pytest.raises(Interrupted) as raised:
            release_start()
        release_start()  # nothing held any more
    assert raised.value.signal == "SIGINT"


def test_a_signal_held_when_the_command_ends_is_dropped_with_the_handlers():
    previous = signal.getsignal(signal.SIGTERM)
    with stop_signals():
        hold_start()
        signal.raise_signal(signal.SIGTERM)  # the command ended before it let go
    assert signal.getsignal(signal.SIGTERM) is previous
    with stop_signals():  # the next command starts with nothing pending
        release_start()


def test_in_another_thread_the_blocks_change_nothing():
    failed = []

    def command() -> None:
        try:
            with stop_signals(), held():
                hold_start()
                release_start()
        except BaseException as e:  # noqa: BLE001 - reported in the test's thread
            failed.append(e)

    thread = threading.Thread(target=command)
    thread.start()
    thread.join(10)
    assert failed == []
