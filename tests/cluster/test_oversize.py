"""A message larger than cavesim ever sends is dropped by zenoh's transport, before it is
buffered: it never reaches a subscriber and the receiver's memory does not follow it
(cavesim/core/wire/network.py, MAX_MESSAGE_BYTES). Two real sessions on loopback."""

from __future__ import annotations

import resource
import socket
import threading
import time

import zenoh

from cavesim.core.wire.network import MAX_MESSAGE_BYTES, NetworkSettings, open_session

KEY = "cavesim/oversize/frame"
JUNK_MESSAGES = 6  # each four times the limit: 200 MiB in all


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def peak_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


def test_an_oversized_message_never_arrives_and_the_largest_legitimate_one_does():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sizes: list[int] = []
    arrived = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        sizes.append(len(sample.payload.to_bytes()))
        arrived.set()

    with open_session(NetworkSettings(listen=(endpoint,))) as receiver, \
            open_session(NetworkSettings(connect=(endpoint,))) as sender:
        subscriber = receiver.declare_subscriber(KEY, on_sample)
        publisher = sender.declare_publisher(
            KEY, congestion_control=zenoh.CongestionControl.BLOCK)
        largest = bytes(MAX_MESSAGE_BYTES - 2**12)  # a chunk, with room for zenoh's framing
        deadline = time.monotonic() + 30.0  # the link comes up (generous: shared cores)
        while not arrived.is_set() and time.monotonic() < deadline:
            publisher.put(largest)
            arrived.wait(1.0)
        assert sizes and sizes[0] == len(largest), "the largest legitimate message was lost"
        before = peak_rss_bytes()
        junk = bytes(4 * MAX_MESSAGE_BYTES)
        for _ in range(JUNK_MESSAGES):
            publisher.put(junk)
        time.sleep(3.0)  # what would arrive has arrived by now
        grown = peak_rss_bytes() - before
        subscriber.undeclare()
    assert len(junk) not in sizes
    assert grown < 2 * len(junk), f"the receiver grew by {grown / 2**20:.0f} MiB"
