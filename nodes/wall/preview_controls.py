"""The preview window's keyboard, mouse and gamepad as a tracker: they move the head and fly
the wand, and the node publishes the result as the same `TrackingMessage` a real tracker
sends (`cavesim tracker`), so the master's input path is a real CAVE's.

Keys (`BINDINGS`, which the window's help line shows): arrows move the head (left/right,
forward/back), Page Up/Down raise and lower it; W/S/A/D move the wand forward/back/left/
right, E/Q raise and lower it, T/G tilt it up and down (rotor speed), Z/X turn it (the
helicopter's heading); P pauses and resumes the run, R resets the scene, Esc ends the run.
Dragging with the left mouse button moves the wand across, the wheel tilts it. A gamepad's
left stick moves the wand, its right stick the head, its triggers tilt. No pose is
published until the first move, so the scene's own script plays until someone takes over;
pause, reset and quit go to the master as session controls (`SessionControls`) from the
first press on, and the master applies them to every node on the same frame.
"""

from __future__ import annotations

import math
import time

import glfw
import numpy as np

from cavesim.core.wire import HeadState, SessionControls, TrackingMessage, WandState

HEAD_SPEED = 1.0  # m/s
WAND_SPEED = 0.5  # m/s
TILT_SPEED = 30.0  # degrees/s
TURN_SPEED = 60.0  # degrees/s
DRAG_METRES_PER_PIXEL = 0.005
WHEEL_DEGREES = 5.0  # tilt per notch
HEAD_START = (0.0, 0.0, 1.7)
WAND_START = (0.0, 0.0, 1.0)
STICK_DEAD_ZONE = 0.15
MAX_TILT = 90.0

# what each key does, in groups as the help line names them: a move is (what it moves, axis,
# direction), a request one of REQUESTS
BINDINGS: tuple[tuple[str, dict], ...] = (
    ("head", {glfw.KEY_LEFT: ("head", 0, -1), glfw.KEY_RIGHT: ("head", 0, 1),
              glfw.KEY_DOWN: ("head", 1, -1), glfw.KEY_UP: ("head", 1, 1),
              glfw.KEY_PAGE_DOWN: ("head", 2, -1), glfw.KEY_PAGE_UP: ("head", 2, 1)}),
    ("fly", {glfw.KEY_W: ("wand", 1, 1), glfw.KEY_A: ("wand", 0, -1),
             glfw.KEY_S: ("wand", 1, -1), glfw.KEY_D: ("wand", 0, 1),
             glfw.KEY_E: ("wand", 2, 1), glfw.KEY_Q: ("wand", 2, -1)}),
    ("tilt", {glfw.KEY_T: ("tilt", 0, 1), glfw.KEY_G: ("tilt", 0, -1)}),
    ("turn", {glfw.KEY_Z: ("heading", 0, 1), glfw.KEY_X: ("heading", 0, -1)}),
    ("pause", {glfw.KEY_P: "pause"}),
    ("reset", {glfw.KEY_R: "reset"}),
    ("quit", {glfw.KEY_ESCAPE: "quit"}),
)
REQUESTS = ("pause", "reset", "quit")
MOVES = {key: does for _, keys in BINDINGS for key, does in keys.items()
         if does not in REQUESTS}
ASKS = {key: does for _, keys in BINDINGS for key, does in keys.items() if does in REQUESTS}
SPEEDS = {"head": HEAD_SPEED, "wand": WAND_SPEED, "tilt": TILT_SPEED, "heading": TURN_SPEED}
_KEY_NAMES = {glfw.KEY_LEFT: "Left", glfw.KEY_RIGHT: "Right", glfw.KEY_DOWN: "Down",
              glfw.KEY_UP: "Up", glfw.KEY_PAGE_DOWN: "PgDn", glfw.KEY_PAGE_UP: "PgUp",
              glfw.KEY_ESCAPE: "Esc"}  # the others are letters, whose GLFW code is ASCII


def key_name(key: int) -> str:
    return _KEY_NAMES.get(key) or chr(key)


def pressed(controls: SessionControls | None, request: str) -> SessionControls:
    """The controls after a press of `request`'s key: pause toggles, reset counts, quit
    holds."""
    c = controls or SessionControls()
    return SessionControls(c.paused != (request == "pause"), c.resets + (request == "reset"),
                           c.quit or request == "quit")


def help_line() -> str:
    """The preview's one line of help: every group's keys and what they do."""
    return "  ".join(f"{'/'.join(map(key_name, keys))} {group}" for group, keys in BINDINGS)


class PreviewControls:
    def __init__(self, window) -> None:
        self.head = np.array(HEAD_START)
        self.wand = np.array(WAND_START)
        self.tilt = 0.0  # degrees, nose up positive
        self.heading = 0.0  # degrees, 0 = toward the front wall
        self.held: set[int] = set()
        self.touched = False  # someone moved: the pose is ours from now on
        self.controls: SessionControls | None = None  # from the first request on
        self._drag: tuple[float, float] | None = None
        self._last = time.monotonic()
        glfw.set_key_callback(window, self._on_key)
        glfw.set_mouse_button_callback(window, self._on_button)
        glfw.set_cursor_pos_callback(window, self._on_cursor)
        glfw.set_scroll_callback(window, self._on_scroll)

    def advance(self) -> TrackingMessage | None:
        """Move by what is held since the last call; the message to publish (a pose once
        someone moved, the session controls once someone asked), or None before either."""
        now = time.monotonic()
        dt, self._last = min(now - self._last, 0.25), now
        for key in self.held:
            target, axis, sign = MOVES[key]
            self._move(target, axis, sign * SPEEDS[target] * dt)
        self._gamepad(dt)
        if not self.touched and self.controls is None:
            return None
        return TrackingMessage(0, HeadState(tuple(self.head)),
                               WandState(tuple(self.wand), self.orientation()), time.time_ns(),
                               self.touched, self.controls)



    def orientation(self) -> tuple[float, float, float, float]:
        """The wand's quaternion (xyzw): turned by `heading` about z, then tilted about x."""
        h, t = math.radians(self.heading) / 2, math.radians(self.tilt) / 2
        yaw = np.array([0.0, 0.0, math.sin(h), math.cos(h)])
        pitch = np.array([math.sin(t), 0.0, 0.0, math.cos(t)])
        return tuple(_multiply(yaw, pitch).tolist())

    def _move(self, target: str, axis: int, amount: float) -> None:
        if target == "head":
            self.head[axis] += amount
        elif target == "wand":
            self.wand[axis] += amount
        elif target == "tilt":
            self.tilt = min(max(self.tilt + amount, -MAX_TILT), MAX_TILT)
        else:
            self.heading = math.fmod(self.heading + amount, 360.0)

    def _gamepad(self, dt: float) -> None:
        if not glfw.joystick_is_gamepad(glfw.JOYSTICK_1):
            return
        state = glfw.get_gamepad_state(glfw.JOYSTICK_1)
        if state is None:
            return
        axes = state.axes
        sticks = ((0, "wand", 0, 1), (1, "wand", 1, -1), (2, "head", 0, 1), (3, "head", 1, -1))
        for index, target, axis, sign in sticks:
            if abs(axes[index]) > STICK_DEAD_ZONE:
                self._move(target, axis, sign * axes[index] * SPEEDS[target] * dt)
                self.touched = True
        trigger = (axes[5] - axes[4]) / 2  # right trigger up, left trigger down
        if abs(trigger) > STICK_DEAD_ZONE:
            self._move("tilt", 0, trigger * TILT_SPEED * dt)
            self.touched = True

    def _on_key(self, window, key, scancode, action, mods) -> None:
        if key in ASKS:
            if action == glfw.PRESS:
                self.controls = pressed(self.controls, ASKS[key])
            return
        if key not in MOVES:
            return
        self.touched = True
        if action == glfw.PRESS:
            self.held.add(key)
        elif action == glfw.RELEASE:
            self.held.discard(key)

    def _on_button(self, window, button, action, mods) -> None:
        if button == glfw.MOUSE_BUTTON_LEFT:
            self._drag = glfw.get_cursor_pos(window) if action == glfw.PRESS else None

    def _on_cursor(self, window, x: float, y: float) -> None:
        if self._drag is None:
            return
        dx, dy = x - self._drag[0], y - self._drag[1]
        self._drag = (x, y)
        self.wand[0] += dx * DRAG_METRES_PER_PIXEL
        self.wand[2] -= dy * DRAG_METRES_PER_PIXEL  # screen y grows downward
        self.touched = True

    def _on_scroll(self, window, dx: float, dy: float) -> None:
        self._move("tilt", 0, dy * WHEEL_DEGREES)
        self.touched = True


def _multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product of two quaternions (xyzw)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz])
