"""A TCP relay that delays every byte by a fixed time each way: network latency without netem.

    python tests/support/delay_relay.py --listen HOST:PORT --target HOST:PORT --delay-ms 20

Every accepted connection gets its own connection to the target; each direction is a
reader that stamps what it reads and a writer that sends it once the stamp is `delay` old,
so the added latency is constant and does not cap the throughput. A connection closed on
one side is closed on the other once the bytes before the close are delivered. Prints
`listening HOST:PORT` on stdout when it accepts connections; runs until killed.
"""

from __future__ import annotations

import argparse
import queue
import socket
import sys
import threading
import time

CHUNK = 65536


def address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, int(port)


def _read(source: socket.socket, pending: queue.Queue) -> None:
    try:
        while data := source.recv(CHUNK):
            pending.put((time.monotonic(), data))
    except OSError:
        pass
    pending.put((time.monotonic(), b""))  # end of stream, delayed like the data


def _write(pending: queue.Queue, sink: socket.socket, delay: float,
           both: tuple[socket.socket, socket.socket]) -> None:
    try:
        while True:
            stamp, data = pending.get()
            wait = stamp + delay - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            if not data:
                sink.shutdown(socket.SHUT_WR)
                return
            sink.sendall(data)
    except OSError:  # the other side is gone: drop the whole connection
        for s in both:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


def _relay(client: socket.socket, target: tuple[str, int], delay: float) -> None:
    try:
        server = socket.create_connection(target, timeout=5)
    except OSError:
        client.close()
        return
    server.settimeout(None)
    both = (client, server)
    for s in both:
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    threads = []
    for source, sink in ((client, server), (server, client)):
        pending: queue.Queue = queue.Queue()
        threads += [threading.Thread(target=_read, args=(source, pending), daemon=True),
                    threading.Thread(target=_write, args=(pending, sink, delay, both),
                                     daemon=True)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for s in both:
        s.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", type=address, required=True)
    parser.add_argument("--target", type=address, required=True)
    parser.add_argument("--delay-ms", type=float, required=True)
    args = parser.parse_args()
    if not 0 <= args.delay_ms <= 10_000:
        parser.error(f"argument --delay-ms: expected 0..10000, got {args.delay_ms}")
    listener = socket.create_server(args.listen, reuse_port=False)
    print(f"listening {args.listen[0]}:{listener.getsockname()[1]}", flush=True)
    while True:
        client, _ = listener.accept()
        threading.Thread(target=_relay, args=(client, args.target, args.delay_ms / 1000),
                         daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())
