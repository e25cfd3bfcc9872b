"""A test network of Linux network namespaces: hosts on one Ethernet switch, and its faults.

Each host is a namespace with one veth (`eth0`, 10.A.B.H/24); the other end of every veth is
enslaved to a bridge in a "switch" namespace of its own, so nothing is added to the root
namespace. Names carry a per-run prefix (`cvs<run id>-`, the id starting with the test's
pid), so parallel or leftover runs never clash. Faults: a host cut off (its switch port
taken down, as if its cable were pulled) and a share of every packet dropped (iptables'
`statistic` match on each host's input; this kernel has no netem). `close()` kills every
process in the namespaces and deletes them, which deletes their veths, bridge and
iptables rules with them.

Needs root and `ip netns` (iproute2), and iptables for `drop_share`.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zlib
from dataclasses import dataclass, field

PREFIX = "cvs"  # every namespace this module makes is named cvs<run id>-<label>
SWITCH_HOST = 254  # the bridge's own address: where a relay on the switch listens


def unavailable() -> str | None:
    """Why namespaces cannot be made here (a reason to skip), or None."""
    if os.geteuid() != 0:
        return "network namespaces need root (CI runs the suite as root)"
    if shutil.which("ip") is None:
        return "no `ip` command: install the Debian package iproute2"
    # root in a container without CAP_SYS_ADMIN can list namespaces but not add one
    name = f"{PREFIX}{os.getpid()}-probe"
    probe = subprocess.run(["ip", "netns", "add", name], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"`ip netns add` does not work here: {probe.stderr.strip()}"
    ip("netns", "delete", name)
    return None


def ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip()}")


def namespaces() -> list[str]:
    listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    return [line.split()[0] for line in listed.splitlines() if line.strip()]


def _kill_all_in(name: str) -> None:
    pids = subprocess.run(["ip", "netns", "pids", name], capture_output=True,
                          text=True).stdout.split()
    for pid in pids:
        try:
            os.kill(int(pid), 9)
        except ProcessLookupError:
            pass


def remove_stale() -> list[str]:
    """Delete the namespaces of runs whose test process is gone (killed before it could
    clean up); the names removed."""
    removed = []
    for name in namespaces():
        digits = name.removeprefix(PREFIX)
        digits = digits[:len(digits) - len(digits.lstrip("0123456789"))]
        if not name.startswith(PREFIX) or not digits or os.path.exists(f"/proc/{digits}"):
            continue
        _kill_all_in(name)
        subprocess.run(["ip", "netns", "delete", name], capture_output=True)
        removed.append(name)
    return removed


@dataclass
class Network:
    """Hosts on one switch; a context manager that removes everything it made."""

    labels: tuple[str, ...]  # one host per label, addresses .1, .2, ... in this order
    run_id: str = field(default_factory=lambda: str(os.getpid()))
    made: list[str] = field(default_factory=list)  # namespaces created so far

    def __post_init__(self) -> None:
        # Only this run's hosts and switch see the subnet; a per-run one just keeps two
        # runs' logs apart.
        n = zlib.crc32(self.run_id.encode())
        self.subnet = f"10.{(n >> 8) & 255}.{n & 255}"

    @property
    def prefix(self) -> str:
        return f"{PREFIX}{self.run_id}-"

    @property
    def switch(self) -> str:
        return f"{self.prefix}switch"

    def namespace(self, label: str) -> str:
        return f"{self.prefix}{label}"

    def address(self, label: str) -> str:
        return f"{self.subnet}.{self.labels.index(label) + 1}"

    @property
    def switch_address(self) -> str:
        return f"{self.subnet}.{SWITCH_HOST}"

    def via(self, label: str) -> str:
        """The command prefix that runs a command on host `label`."""
        return f"ip netns exec {self.namespace(label)}"

    def _port(self, label: str) -> str:  # the host's port on the switch
        return f"port{self.labels.index(label) + 1}"

    def __enter__(self) -> Network:
        try:
            self.build()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def build(self) -> None:
        self._add(self.switch)
        ip("-n", self.switch, "link", "add", "br0", "type", "bridge")
        ip("-n", self.switch, "addr", "add", f"{self.switch_address}/24", "dev", "br0")
        ip("-n", self.switch, "link", "set", "br0", "up")
        for label in self.labels:
            host, port = self.namespace(label), self._port(label)
            self._add(host)
            # made inside the host, its peer straight into the switch: never in the root ns
            ip("-n", host, "link", "add", "eth0", "type", "veth", "peer", "name", port,
               "netns", self.switch)
            ip("-n", self.switch, "link", "set", port, "master", "br0", "up")
            ip("-n", host, "addr", "add", f"{self.address(label)}/24", "dev", "eth0")
            ip("-n", host, "link", "set", "eth0", "up")

    def _add(self, name: str) -> None:
        ip("netns", "add", name)
        self.made.append(name)
        ip("-n", name, "link", "set", "lo", "up")

    # -- running things and faults ------------------------------------------------------------

    def popen(self, label: str | None, argv: list[str], **kwargs) -> subprocess.Popen:
        """Start argv on host `label` (None: on the switch)."""
        where = self.switch if label is None else self.namespace(label)
        return subprocess.Popen(["ip", "netns", "exec", where, *argv], **kwargs)

    def set_link(self, label: str, up: bool) -> None:
        """Plug host `label`'s cable into the switch, or pull it (the port goes down)."""
        ip("-n", self.switch, "link", "set", self._port(label), "up" if up else "down")

    def drop_share(self, probability: float) -> None:
        """Every host drops this share of the packets it receives from the network."""
        for label in self.labels:
            done = subprocess.run(
                ["ip", "netns", "exec", self.namespace(label), "iptables", "-A", "INPUT",
                 "-i", "eth0", "-m", "statistic", "--mode", "random", "--probability",
                 f"{probability:.4f}", "-j", "DROP"], capture_output=True, text=True)
            if done.returncode != 0:
                raise RuntimeError(f"iptables in {self.namespace(label)}: "
                                   f"{done.stderr.strip()}")

    # -- cleaning up -----------------------------------------------------------------------------

    def close(self) -> None:
        """Kill every process in our namespaces, then delete them (veths, bridge, rules go
        with them). Safe to call twice; raises if something of ours is left."""
        for name in reversed(self.made):
            _kill_all_in(name)
        for name in reversed(self.made):
            subprocess.run(["ip", "netns", "delete", name], capture_output=True)
        self.made.clear()
        left = self.leftovers()
        if left:
            raise RuntimeError(f"network namespaces left behind: {left}")

    def leftovers(self) -> list[str]:
        return [name for name in namespaces() if name.startswith(self.prefix)]
