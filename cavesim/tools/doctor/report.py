"""`cavesim doctor`'s findings: gathered, judged, written as JSON and shown as tables."""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from cavesim.core.errors import ContextError
from cavesim.core.output import check_written, writing
from cavesim.core.wire.network import NetworkSettings
from cavesim.gpu.gl.devices import list_devices
from cavesim.gpu.gl.driver import VENDOR_VARIABLE, Driver, SystemDriver, library_name
from cavesim.tools.doctor.checks import check_windows, check_zenoh
from cavesim.tools.doctor.probe import LIMITS, probe
from cavesim.tools.doctor.verdict import Verdict, judge


def gather(network: NetworkSettings, driver: Driver | None = None,
           probe_device: Callable[[int, tuple[str, ...]], dict] = probe) -> dict:
    """Everything the doctor looks at, as JSON-ready values (the verdict comes after).
    `driver` and `probe_device` stand in for this machine's in tests."""
    egl = {"library": library_name(), "vendor_files": os.environ.get(VENDOR_VARIABLE)}
    try:
        driver = driver or SystemDriver()
        egl["client_extensions"] = driver.client_extensions()
        listed = list_devices(driver)
    except ContextError as e:
        egl.update(problem=e.problem, fix=e.fix)
        listed = ()
    return {"cavesim": cavesim_version(), "python": platform.python_version(),
            "host": platform.node(), "egl": egl,
            "devices": [{**device.summary(), **probe_device(device.index, device.extensions)}
                        for device in listed],
            "zenoh": check_zenoh(network), "windows": check_windows()}


def cavesim_version() -> str:
    """The installed distribution's version, or where a source tree pip never installed
    runs from."""
    try:
        return metadata.version("cavesim")
    except metadata.PackageNotFoundError:
        return f"source tree at {Path(__file__).resolve().parents[3]} (not installed)"


def run_doctor(network: NetworkSettings, out: Path, console: Console) -> Verdict:
    """Examine this node, write `out` (doctor.json), print the tables; the verdict."""
    findings = gather(network)
    verdict = judge(findings)
    findings["verdict"] = verdict.summary()
    with writing(out):
        out.write_text(json.dumps(findings, indent=2) + "\n")
    if findings["devices"]:
        console.print(device_table(findings["devices"]))
    if any(d["opened"] for d in findings["devices"]):
        console.print(limit_table(findings["devices"]))
    console.print(node_table(findings))
    for warning in verdict.warnings:
        console.print(f"[yellow]warning:[/] {escape(warning)}")
    if verdict.ok:  # a failure is the command's one error line, with the fix
        console.print(f"[green]ok:[/] {escape(verdict.reason)}")
    check_written(out)
    console.print(f"wrote {escape(str(out))}")
    return verdict


def device_table(devices: list[dict]) -> Table:
    table = Table(title="EGL devices")
    for column in ("device", "kind", "DRM node", "GL renderer", "OpenGL version",
                   "largest capacity", "checks"):
        table.add_column(column)
    for d in devices:
        checks = "[green]ok" if d["usable"] else f"[red]{escape(d['problem'])}"
        table.add_row(str(d["index"]), d["kind"], escape(d["render_node"] or d["drm_file"] or "-"),
                      escape(d.get("renderer", "-")), escape(d.get("version", "-")),
                      f"{d['largest_capacity']:,}" if d["opened"] else "-", checks)
    return table


def limit_table(devices: list[dict]) -> Table:
    opened = [d for d in devices if d["opened"]]
    table = Table(title="GL limits")
    table.add_column("limit")
    for d in opened:
        table.add_column(f"device {d['index']}", justify="right")
    for name in LIMITS:
        table.add_row(name, *(escape(_shown(d["limits"][name])) for d in opened))
    return table


def node_table(findings: dict) -> Table:
    zenoh, windows = findings["zenoh"], findings["windows"]
    session = f"opened, zid {zenoh['zid']}" if zenoh["opened"] else f"[red]{escape(zenoh['error'])}"
    reached = ", ".join(zenoh["peers"] + zenoh["routers"]) or "-"
    window = "can open" if windows["can_open"] else escape(windows["reason"])
    rows = [("EGL library", escape(str(findings["egl"]["library"]))),
            ("zenoh-python", zenoh["version"]), ("zenoh mode", zenoh["mode"]),
            ("listen", escape(", ".join(zenoh["listen"]) or "-")),
            ("connect", escape(", ".join(zenoh["connect"]) or "-")),
            ("zenoh session", session), ("peers and routers reached", reached),
            ("windows (glfw)", window),
            ("DISPLAY", escape(windows["display"] or "(not set)"))]
    table = Table(title="node")
    table.add_column("what")
    table.add_column("found")
    for name, value in rows:
        table.add_row(name, value)
    return table


def _shown(value) -> str:
    if isinstance(value, list):
        return " x ".join(f"{v:,}" for v in value)
    return f"{value:,}" if isinstance(value, int) else str(value)
