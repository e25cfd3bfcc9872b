"""Extreme inputs: what each one does, what the user sees, and that no NaN reaches the GPU.

Each case returns a row: `outcome` is one of
  rejected - refused where it enters (the master, the decoder, the scene loader), with an
             error that names it;
  clamped  - pulled back into range, with a logged warning;
  dropped  - the particle pass drops the particles, for the reason `user_sees` names;
  stable   - run as given, and the state stays finite.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from cavesim.core.clock import Clock, check_dt
from cavesim.core.errors import ProtocolError, SceneError
from cavesim.core.helicopter.flight import clamp_wand
from cavesim.core.limits import SPEED_LIMIT
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator, parse_scene
from cavesim.core.wire import HeadState, TrackingMessage, WandState, decode, encode
from cavesim.core.wire.envelope import HEADER, MAGIC, VERSION, Kind, session_id
from cavesim.core.wire.payloads.poses import POSED, TRACKING
from cavesim.gpu.engine import FrameInput, ParticleSystem

IDENTITY = np.eye(3, dtype=np.float32)


def busy_scene(integrator=Integrator.EXPLICIT_EULER, capacity=4000, rate=3000.0, speed=1.0,
               emitters=True):
    """Sand and fine dust in a uniform wind, over a ground plane, fed by one emitter."""
    return parse_scene(busy_scene_data(integrator, capacity, rate, speed, emitters),
                       name="extreme")


def busy_scene_data(integrator=Integrator.EXPLICIT_EULER, capacity=4000, rate=3000.0,
                    speed=1.0, emitters=True) -> dict:
    """`busy_scene` as the dict a scene file gives."""
    return {
        "simulation": {"capacity": capacity, "seed": 3, "integrator": integrator.value,
                       "random_texture_size": 16},
        "particle_class": [{"name": "sand", "diameter": 150e-6, "density": 2650.0},
                           {"name": "dust", "diameter": 10e-6, "density": 2650.0}],
        "emitter": [{"name": "e", "position": [0, 0, 1], "extent": [2, 2, 0.5], "rate": rate,
                     "speed": 2.0, "lifetime": [1.0, 3.0], "particle_class": "sand"},
                    {"name": "f", "position": [1, 0, 1], "rate": rate, "speed": 1.0,
                     "lifetime": [1.0, 3.0], "particle_class": "dust"}] if emitters else [],
        "forces": {"gravity": [0, 0, -9.81], "drag": {}},
        "field": {"kind": "uniform", "box_min": [-50, -50, 0], "box_max": [50, 50, 50],
                  "resolution": [2, 2, 2], "params": {"velocity": [speed, 0.0, 0.0]}},
        "collision": {"kind": "plane", "friction": 0.3, "resilience": 0.3},
    }


def finite_state(system: ParticleSystem) -> bool:
    p = system.read_particles()
    return bool(np.isfinite(p["pos"]).all() and np.isfinite(p["vel"]).all()
                and np.isfinite(p["age"]).all())


def _steps(system: ParticleSystem, dt: float, frames: int) -> None:
    for _ in range(frames):
        system.step(FrameInput(dt, IDENTITY))


def _row(case: str, outcome: str, sees: str, finite: bool = True, **figures) -> dict:
    return {"case": case, "outcome": outcome, "user_sees": sees, "state_finite": finite,
            **figures}


def dt_spike(ctx) -> list[dict]:
    wall = [0.0]
    clock = Clock(1 / 60, realtime=True, now=lambda: wall[0],
                  sleep=lambda s: wall.__setitem__(0, wall[0] + s))
    clock.wait_for_frame()
    wall[0] += 1.0  # the hitch
    hitch_ends, sent = wall[0], []
    while wall[0] == hitch_ends:
        sent.append(clock.wait_for_frame())
    burst = len(sent) - 1  # the last one came after a wait
    rows = [_row("dt spike of 1 s (master, real time)", "clamped",
                 f"a warning; the hitch becomes {burst} frames of {clock.dt:.4f} s back to "
                 f"back and {clock.dropped_seconds:.2f} s are dropped", True,
                 max_dt_sent=max(sent), frames_in_burst=burst)]
    for integrator in (Integrator.EXPLICIT_EULER, Integrator.EXPONENTIAL, Integrator.ETD2RK):
        system = ParticleSystem(ctx, busy_scene(integrator))
        _steps(system, 1 / 60, 30)
        cloud = system.read_particles()
        system.release()
        # the same cloud, none expiring and nothing emitted: every particle the 1 s frame
        # (one reaching the engine anyway) loses ran away
        cloud["lifetime"] = 1e6
        system = ParticleSystem(ctx, busy_scene(integrator, emitters=False))
        system.write_particles(cloud)
        _steps(system, 1.0, 1)
        ran_away = len(cloud) - system.live_count
        fastest = float(np.abs(system.read_particles()["vel"]).max(initial=0.0))
        sees = (f"{ran_away} of {len(cloud)} particles ran away and were dropped; the rest "
                f"moved on" if ran_away else
                f"no particle ran away: all {len(cloud)} moved on, the fastest at "
                f"{fastest:.3g} m/s")
        rows.append(_row(f"dt spike of 1 s (engine, {integrator.value})", "stable", sees,
                         finite_state(system), particles=len(cloud), ran_away=ran_away,
                         fastest=fastest))
        system.release()
    return rows


def launch_speed(ctx) -> list[dict]:
    """Particles launched far beyond any flow: an emitter is refused, a written state is
    dropped at its first step."""
    data = busy_scene_data()
    data["emitter"][0]["speed"] = 1e14
    try:
        parse_scene(data, name="extreme")
        rows = [_row("emitter launching at 1e14 m/s", "ACCEPTED", "nothing")]
    except SceneError as e:
        rows = [_row("emitter launching at 1e14 m/s", "rejected", str(e))]
    system = ParticleSystem(ctx, busy_scene(Integrator.ETD2RK, emitters=False))
    launched = np.zeros(100, dtype=PARTICLE_DTYPE)
    launched["pos"] = (0.0, 0.0, 1.0)
    launched["vel"] = (1e14, 0.0, 0.0)
    launched["lifetime"] = 1e6
    launched["class_id"] = 1  # dust
    system.write_particles(launched)
    _steps(system, 1 / 60, 1)
    rows.append(_row("dust launched at 1e14 m/s", "dropped",
                     f"faster than the speed limit ({SPEED_LIMIT:g} m/s per component), which "
                     f"float32 cannot step: dropped at the first step, "
                     f"{len(launched) - system.live_count} of {len(launched)}",
                     finite_state(system), live=system.live_count))
    system.release()
    return rows


def zero_dt(ctx) -> list[dict]:
    system = ParticleSystem(ctx, busy_scene())
    _steps(system, 1 / 60, 20)
    before = system.read_particles()
    _steps(system, 0.0, 5)
    after = system.read_particles()
    still = np.array_equal(before["pos"], after["pos"]) and len(before) == len(after)
    system.release()
    return [_row("dt = 0", "stable", "a paused frame: nothing moves, nothing is emitted",
                 still, unchanged=bool(still))]


def bad_dt() -> list[dict]:
    rows = []
    for name, dt in (("negative dt", -1 / 60), ("NaN dt", math.nan), ("infinite dt", math.inf)):
        messages = []
        for check, argument in ((check_dt, (dt,)), (FrameInput, (dt, IDENTITY))):
            try:
                check(*argument)
            except ValueError as e:
                messages.append(str(e))
        rows.append(_row(name, "rejected" if len(messages) == 2 else "ACCEPTED",
                         messages[0] if messages else "nothing", True))
    return rows


def bad_wand() -> list[dict]:
    rows = []
    for name, value in (("NaN wand", math.nan), ("infinite wand", math.inf)):
        # head (position, orientation), wand (position, orientation, buttons, axes), sent_ns,
        # flags, resets: a posed message whose wand x is `value`
        body = TRACKING.pack(0, 0, 1.7, 0, 0, 0, 1, value, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0,
                             POSED, 0)
        data = HEADER.pack(MAGIC, VERSION, Kind.TRACKING, 0, 0, session_id("s"), 0, 0,
                           len(body)) + body
        try:
            decode(data, "s")
            rows.append(_row(name, "ACCEPTED", "nothing"))
        except ProtocolError as e:  # for its value: a message refused for its header
            # would prove nothing about the wand
            rows.append(_row(name, "rejected" if e.reason == "bad-value" else "ACCEPTED",
                             f"the message is dropped and counted: {e}"))
    huge = TrackingMessage(0, HeadState(), WandState((1e30, -1e30, 2.0)))
    decoded = decode(encode(huge, "s"), "s")
    clamped, changed = clamp_wand(decoded.wand.position)
    rows.append(_row("huge wand (1e30 m)", "clamped" if changed else "ACCEPTED",
                     f"a warning; the wand is held at {clamped}", True))
    return rows


def huge_field(ctx) -> list[dict]:
    system = ParticleSystem(ctx, busy_scene(Integrator.EXPONENTIAL, speed=1e6))
    _steps(system, 1 / 60, 30)
    row = _row("field of 1e6 m/s", "stable", "dust blown out of the scene at 1e6 m/s",
               finite_state(system), live=system.live_count)
    system.release()
    return [row]


def far_outside(ctx) -> list[dict]:
    system = ParticleSystem(ctx, busy_scene(emitters=False))
    far = np.zeros(100, dtype=PARTICLE_DTYPE)
    far["pos"] = (1e6, -1e6, 1e6)
    far["lifetime"] = 1e6
    system.write_particles(far)
    _steps(system, 1 / 60, 10)
    row = _row("particles 1e6 m outside the domain", "stable",
               "they feel the flow at the nearest edge of the field box (clamp rule)",
               finite_state(system), live=system.live_count)
    system.release()
    return [row]


def flood(ctx) -> list[dict]:
    system = ParticleSystem(ctx, busy_scene(capacity=1000, rate=1e9))
    _steps(system, 1 / 60, 3)
    row = _row("emission of 1e9/s beyond capacity", "stable",
               "the capacity holds; what does not fit is dropped the same way on every node",
               finite_state(system), live=system.live_count, capacity=1000)
    system.release()
    return [row]


def empty(ctx) -> list[dict]:
    rows = []
    for name, scene in (("zero capacity", busy_scene(capacity=0)),
                        ("empty scene", dataclasses.replace(busy_scene(emitters=False),
                                                            capacity=0))):
        system = ParticleSystem(ctx, scene)
        _steps(system, 1 / 60, 10)
        rows.append(_row(name, "stable", "nothing to draw; the frames go on",
                         finite_state(system), live=system.live_count))
        system.release()
    return rows


CASES: tuple[Callable, ...] = (dt_spike, zero_dt, huge_field, far_outside, launch_speed, flood,
                               empty)
PURE_CASES: tuple[Callable, ...] = (bad_dt, bad_wand)


def run_extremes(ctx) -> list[dict]:
    return [row for case in PURE_CASES for row in case()] + \
        [row for case in CASES for row in case(ctx)]
