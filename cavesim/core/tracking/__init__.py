"""Tracking systems into the wire's head and wand, without GL or sockets.

DTrack2's ASCII datagrams are parsed and checked (`dtrack`), mapped from DTrack's room and
bodies into the CAVE's room (`mapping`, read from a TOML file) and kept from datagram to
datagram (`state`); `nodes.tracker.bridge` is the process that receives and publishes.
"""

from cavesim.core.tracking.dtrack import Body, Datagram, Flystick, parse_datagram
from cavesim.core.tracking.mapping import Target, Tracked, TrackerMapping, load_mapping
from cavesim.core.tracking.state import TrackingState

__all__ = ["Body", "Datagram", "Flystick", "Target", "Tracked", "TrackerMapping",
           "TrackingState", "load_mapping", "parse_datagram"]
