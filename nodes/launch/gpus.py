"""Which EGL device each node of a `cavesim run` computes on, on a machine with several GPUs,
and which walls share a node."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence

from cavesim.core.errors import ContextError
from cavesim.gpu.gl.devices import EglDevice, no_such_device


def spread_walls(walls: Sequence[str], pinned: Mapping[str, int],
                 devices: Sequence[EglDevice]) -> dict[str, int]:
    """The EGL device of each wall that is given one (`cavesim node --gpu`).

    A wall pinned by the CAVE file keeps its device; every other wall goes to the hardware
    device with the fewest walls so far (ties: the lowest index), which is round-robin
    when nothing is pinned. A software device (llvmpipe) is never chosen: without a
    hardware device the other walls are given none and use the default device.
    """
    devices = tuple(devices)
    for wall, index in pinned.items():
        if not 0 <= index < len(devices):
            error = no_such_device(index, devices)
            raise ContextError(f"wall {wall!r}: {error.problem}", error.fix)
    hardware = [d.index for d in devices if not d.software]
    load = Counter(index for wall, index in pinned.items() if wall in walls)
    chosen = {}
    for wall in walls:
        if wall in pinned:
            chosen[wall] = pinned[wall]
        elif hardware:
            chosen[wall] = min(hardware, key=lambda index: (load[index], index))
            load[chosen[wall]] += 1
    return chosen


GROUPINGS = ("cave", "wall", "gpu")  # `cavesim run --group-by`: see its help


def by_gpu(walls: Sequence[str], gpus: Mapping[str, int]
           ) -> tuple[dict[str, tuple[str, ...]], dict[str, int]]:
    """One node per EGL device, named gpuN, drawing the walls that compute on it (a wall
    given no device: the default device, 0), and each node's device."""
    nodes: dict[str, tuple[str, ...]] = {}
    devices: dict[str, int] = {}
    for wall in walls:
        node = f"gpu{gpus.get(wall, 0)}"
        nodes[node] = (*nodes.get(node, ()), wall)
        if wall in gpus:
            devices[node] = gpus[wall]
    return nodes, devices
