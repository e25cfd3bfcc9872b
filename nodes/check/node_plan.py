"""What the harness's plan asks of each node before the run: the faults it does itself
(its own, and the divergences of the kinds served to a resync), its part as a collision's
resync source, how it resyncs, and the breach budget that leaves room for all of them."""

from __future__ import annotations

from collections import Counter

from nodes.faults import (
    COLLISIONS,
    DIVERGING,
    NODE_FAULTS,
    STRAGGLER_RESTART,
    Fault,
    divergence_frames,
    last_action,
)
from nodes.master.budgets import Budget

STATE_FORGERIES = ("snapshot-forgery", *COLLISIONS)  # served to a node's resync


def with_room(budget: Budget, faults: tuple[Fault, ...]) -> Budget:
    """`budget`, or more: room for as many breaches as the faults the plan has one node do
    itself (each diverges once at most), so that the harness's own
    faults give no node up."""
    planned = Counter(own.node for f in faults for own in injected(f))
    return Budget(max(budget.most, *planned.values(), 1), budget.window)


def master_kill_frame(faults: tuple[Fault, ...]) -> int | None:
    """The frame of the plan's master-kill (None without one); ValueError when a fault the
    nodes do themselves comes at or after it, or a straggler's restart (the new master's
    run numbers its frames from 1 again: a node could not tell which frame was meant)."""
    kill = next((f.frame for f in faults if f.kind == "master-kill"), None)
    late = [str(f) for f in faults if kill is not None and any(
        last_action(own) >= kill for own in injected(f))]
    if late:
        raise ValueError(f"{', '.join(late)}: a node's own fault (and a straggler's restart, "
                         f"{STRAGGLER_RESTART} frames on) must come before the master-kill@"
                         f"{kill} (the new master's run counts frames from 1)")
    return kill


def node_arguments(faults: tuple[Fault, ...], common: tuple[str, ...], wall: str,
                    walls: tuple[str, ...], after: int = 0) -> tuple[str, ...]:
    """`wall`'s node's arguments: the `common` ones, what it must do itself for the faults
    after frame `after` (a restarted node is not given those it has passed: its own, and its
    part as another's resync source) and how it resyncs."""
    own = [str(f) for fault in faults for f in (*injected(fault), *withheld(fault, walls))
           if f.node == wall and f.frame > after]
    return (*common, *(arg for f in own for arg in ("--inject", f)),
            *full_resync(faults, wall))


def full_resync(faults: tuple[Fault, ...], wall: str) -> tuple[str, ...]:
    """A wall that forged states are served to resyncs by full snapshot only (a delta
    would heal it before any snapshot was asked for); the last --resync counts."""
    if any(f.kind in STATE_FORGERIES and f.node == wall for f in faults):
        return ("--resync", "full")
    return ()


def injected(fault: Fault) -> tuple[Fault, ...]:
    """What the node itself must do for `fault`: its own faults, and the divergences of the
    kinds that make their node diverge (DIVERGING: forged states are served to its resync,
    queries replayed against it)."""
    if fault.kind in NODE_FAULTS:
        return (fault,)
    if fault.kind in DIVERGING:
        return tuple(Fault("bitflip", k, fault.node) for k in divergence_frames(fault))
    return ()


def resync_roles(fault: Fault, walls: tuple[str, ...]) -> tuple[str, str]:
    """(source, confirmer) of the first try to resync the node of a collision: the first two
    other walls, as the master names them (`lockstep.holders`, all walls agreeing)."""
    source, confirmer, *_ = (w for w in walls if w != fault.node)
    return source, confirmer


def withheld(fault: Fault, walls: tuple[str, ...]) -> tuple[Fault, ...]:
    """What a collision's resync source does for it: it withholds its answer to the first
    state query of each divergence's frame, so that the forged twin comes alone and is
    judged every time."""
    if fault.kind not in COLLISIONS:
        return ()
    source, _ = resync_roles(fault, walls)
    return tuple(Fault("withhold", k, source) for k in divergence_frames(fault))
