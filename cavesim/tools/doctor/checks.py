"""The doctor's checks beyond the GPU: the zenoh session this node would open, and whether
it can open windows (live walls). Both report; neither raises."""

from __future__ import annotations

import json
import os
import threading
from importlib import metadata

from cavesim.core.errors import ClusterError
from cavesim.core.wire.network import NetworkSettings, open_session, zenoh_config, zenoh_message

ZENOH_DEADLINE = 5.0  # s to open the session and, with endpoints to connect to, reach one


def check_zenoh(network: NetworkSettings, deadline: float = ZENOH_DEADLINE) -> dict:
    """zenoh-python's version, the mode and endpoints this node would use, and whether a
    session opens within `deadline` s (with its id, and the peers and routers it reached)."""
    config = zenoh_config(network)
    mode = json.loads(config.get_json("mode")) or "peer"
    found = {"version": metadata.version("eclipse-zenoh"), "mode": mode,
             "listen": _for_mode(config.get_json("listen/endpoints"), mode),
             "connect": _for_mode(config.get_json("connect/endpoints"), mode),
             "multicast_scouting": json.loads(config.get_json("scouting/multicast/enabled")),
             "opened": False, "zid": None, "peers": [], "routers": [], "error": None}
    done = threading.Event()

    def attempt() -> None:
        try:
            with open_session(network) as session:
                found["opened"], found["zid"] = True, str(session.info.zid())
                if found["connect"]:  # wait (to the deadline) for a first transport
                    reached = threading.Event()
                    listener = session.info.declare_transport_events_listener(
                        lambda event: reached.set(), history=True)
                    reached.wait(deadline)
                    listener.undeclare()
                found["peers"] = [str(z) for z in session.info.peers_zid()]
                found["routers"] = [str(z) for z in session.info.routers_zid()]
        except ClusterError as e:  # zenoh's own error, on one line
            found["error"] = zenoh_message(e.__cause__ or e)
        finally:
            done.set()

    threading.Thread(target=attempt, daemon=True).start()
    if not done.wait(2 * deadline):  # a hung open: the daemon thread is left behind
        return {**found, "error": f"the session did not open within {2 * deadline:.0f} s"}
    return found


def check_windows() -> dict:
    """Whether glfw can start with this DISPLAY (optional: walls also render to files)."""
    found = {"display": os.environ.get("DISPLAY"),
             "wayland_display": os.environ.get("WAYLAND_DISPLAY"), "glfw": None,
             "can_open": False, "reason": None}
    try:
        import glfw
    except ImportError as e:
        return {**found, "reason": f"the glfw package is not installed ({e}); "
                                   f"`pip install glfw` for windows"}
    found["glfw"] = glfw.__version__
    errors: list[str] = []
    glfw.set_error_callback(lambda code, text: errors.append(
        text.decode(errors="replace") if isinstance(text, bytes) else str(text)))
    try:
        started = glfw.init()
    except glfw.GLFWError as e:  # raised instead of reported when ERROR_REPORTING says so
        started, errors = False, [*errors, str(e)]
    if started:
        glfw.terminate()
        return {**found, "can_open": True}
    return {**found, "reason": f"glfw.init() failed: {errors[-1] if errors else 'no reason'}"}


def _for_mode(text: str, mode: str) -> list[str]:
    """Endpoints as zenoh keeps them: a list, or a list per mode."""
    value = json.loads(text)
    return list(value.get(mode, []) if isinstance(value, dict) else value or [])
