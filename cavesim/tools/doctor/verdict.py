"""Whether a node can run cavesim, from what the doctor found: one reason, one fix, and
warnings about what works but may surprise (a default device that cannot run, no window)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from cavesim.gpu.gl.driver import PACKAGE_HINT

ZENOH_FIX = ("check --listen, --connect and --config: a port already in use, or an address "
             "that is not this host's")


@dataclass(frozen=True)
class Verdict:
    ok: bool
    reason: str  # one line
    fix: str = ""  # one line; empty when ok
    warnings: tuple[str, ...] = ()
    largest_capacity: int = 0  # particles per wall on the best device; 0 when not ok
    state_bytes: int = 0  # one particle buffer of that many particles

    def summary(self) -> dict:
        return {**asdict(self), "warnings": list(self.warnings)}


def judge(findings: dict) -> Verdict:
    """The verdict on `findings` (doctor.json without its verdict).

    A node can run cavesim when at least one EGL device passed its probe (GL 4.3 core, the
    limits the engine needs, the checksum program agreeing with numpy) and the zenoh
    session opens. Windows are optional: they only ever warn.
    """
    egl, devices, zenoh = findings["egl"], findings["devices"], findings["zenoh"]
    if egl.get("problem"):
        return Verdict(False, egl["problem"], egl["fix"])
    if not devices:
        return Verdict(False, "libEGL lists no EGL device", PACKAGE_HINT)
    usable = [d for d in devices if d["usable"]]
    if not usable:
        problems = "; ".join(f"device {d['index']} ({d['kind']}): {d['problem']}"
                             for d in devices)
        return Verdict(False, f"no EGL device can run cavesim: {problems}", devices[0]["fix"])
    if not zenoh["opened"]:
        return Verdict(False, f"the zenoh session does not open: {zenoh['error']}", ZENOH_FIX)
    best = max(usable, key=lambda d: d["largest_capacity"])
    indices = ", ".join(f"{d['index']} ({d['kind']}, {d['renderer']})" for d in usable)
    size = binary_size(best["state_bytes"])
    return Verdict(True, f"this node can run cavesim on EGL device(s) {indices}; up to "
                         f"{best['largest_capacity']:,} particles per wall on device "
                         f"{best['index']} ({size} per particle buffer)",
                   warnings=tuple(_warnings(findings, usable)),
                   largest_capacity=best["largest_capacity"], state_bytes=best["state_bytes"])


def binary_size(size: int) -> str:
    """3_355_443 * 40 -> '128 MiB'; 2**31 -> '2.00 GiB'."""
    return f"{size / 2**30:.2f} GiB" if size >= 2**30 else f"{size / 2**20:.0f} MiB"


def _warnings(findings: dict, usable: list[dict]) -> list[str]:
    devices, zenoh, windows = findings["devices"], findings["zenoh"], findings["windows"]
    found = [f"EGL device {d['index']} ({d['kind']}) cannot run cavesim: {d['problem']}"
             for d in devices if not d["usable"]]
    if not devices[0]["usable"]:
        found.append(f"the default EGL device 0 cannot run cavesim: give nodes "
                     f"--gpu {usable[0]['index']} (or `gpu` in the CAVE file)")
    if zenoh["connect"] and not (zenoh["peers"] or zenoh["routers"]):
        found.append(f"no zenoh peer or router answered at {', '.join(zenoh['connect'])} "
                     f"(is the master up?)")
    if not windows["can_open"]:
        found.append(f"windows cannot open: {windows['reason']} (optional: walls render to "
                     f"files)")
    return found
