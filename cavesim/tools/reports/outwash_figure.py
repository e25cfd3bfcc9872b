"""outwash.png: the brownout demo's downwash against the published radial wall-jet data it is
validated by (the numbers are tests/unit/test_downwash.py's). Written into the README's images by
`python -m cavesim.tools.reports.outwash_figure [path]`.

Panels: the flow under a hovering rotor one radius up (speed, streamlines of the stream
function); the wall jet's peak speed and half-width against distance for three hover
heights beside Poreh, Tsuei & Cermak's correlations; vertical profiles beside Verhoff's.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: no display, no GUI event loop
import matplotlib.pyplot as plt  # noqa: E402  (must follow the backend choice)
import numpy as np  # noqa: E402

from cavesim.core.helicopter.downwash import downwash, stream_function  # noqa: E402
from cavesim.core.helicopter.outwash import (  # noqa: E402
    outwash_profile,
    poreh_half_width,
    poreh_peak_speed,
    verhoff_profile,
)
from cavesim.core.helicopter.rotor import induced_velocity  # noqa: E402
from cavesim.core.scene import load_scene  # noqa: E402
from cavesim.core.scene.model import Helicopter  # noqa: E402

SCENE = "config/scenes/brownout.toml"
HEIGHTS = (0.41, 1.0, 2.0)  # hub heights in rotor radii: on its skids, one and two up
DISTANCES = np.linspace(0.3, 10.0, 60)  # r / R
PROFILE_DISTANCES = (2.0, 4.0, 8.0)  # r / R, at one radius up
DEFAULT_PATH = Path("docs/images/outwash.png")


def _flow_panel(ax, helicopter: Helicopter, v_hover: float) -> None:
    R = helicopter.rotor_radius
    r, z = np.meshgrid(np.linspace(0.0, 4.0, 161) * R, np.linspace(0.0, 2.0, 81) * R)
    points = np.column_stack([r.ravel(), np.zeros(r.size), z.ravel()])
    hub, v_i = (0.0, 0.0, R), induced_velocity(helicopter, 1.0, R)
    u = downwash(points, hub, v_i, R, 0.0)
    speed = np.hypot(u[:, 0], u[:, 2]).reshape(r.shape) / v_hover
    shaded = ax.contourf(r / R, z / R, speed, levels=np.linspace(0.0, 1.8, 19), extend="max")
    psi = stream_function(points + [0.0, 0.0, 1e-9], hub, v_i, R, 0.0).reshape(r.shape)
    ax.contour(r / R, z / R, psi, levels=24, colors="white", linewidths=0.5)
    ax.plot([0.0, 1.0], [1.0, 1.0], color="red", linewidth=2.5)
    ax.set_aspect("equal")
    ax.set_xlabel("r / R")
    ax.set_ylabel("z / R")
    ax.set_title("hover one radius up: |u| / v_h, streamlines", fontsize=9)
    plt.colorbar(shaded, ax=ax, shrink=0.8)


def _jet_panels(speed_ax, width_ax, helicopter: Helicopter, v_hover: float) -> None:
    R = helicopter.rotor_radius
    for height, colour in zip(HEIGHTS, ("tab:red", "tab:blue", "tab:green"), strict=True):
        h = height * R
        v_i = induced_velocity(helicopter, 1.0, h)
        profiles = [outwash_profile(d * R, h, v_i, R) for d in DISTANCES]
        label = f"h = {height:g} R"
        speed_ax.plot(DISTANCES, [p.peak_speed / v_hover for p in profiles], color=colour,
                      label=f"model, {label}")
        speed_ax.plot(DISTANCES, poreh_peak_speed(v_hover, R, h, DISTANCES * R) / v_hover,
                      color=colour, linestyle="--", linewidth=0.9)
        width_ax.plot(DISTANCES, [p.half_width / R for p in profiles], color=colour)
        width_ax.plot(DISTANCES, poreh_half_width(R, h, DISTANCES * R) / R, color=colour,
                      linestyle="--", linewidth=0.9)
    for ax in (speed_ax, width_ax):
        ax.axvspan(5.0, DISTANCES[-1], color="0.9", zorder=0)
        ax.set_xlabel("r / R")
        ax.grid(True, linewidth=0.4, alpha=0.5)
    speed_ax.set_ylim(0.0, 2.2)
    speed_ax.axhline(2.0, color="0.4", linewidth=0.7, linestyle=":")
    speed_ax.set_ylabel("peak outwash u_max / v_h")
    speed_ax.set_title("peak outwash; dashed: Poreh et al. 1967 (held to 10% in grey)",
                       fontsize=9)
    speed_ax.legend(fontsize=7)
    width_ax.set_ylim(0.0, 1.2)
    width_ax.set_ylabel("half-width delta / R")
    width_ax.set_title("wall-jet half-width; dashed: Poreh et al. (15% in grey)", fontsize=9)


def _profile_panel(ax, helicopter: Helicopter) -> None:
    R = helicopter.rotor_radius
    v_i = induced_velocity(helicopter, 1.0, R)
    eta = np.linspace(0.0, 2.5, 400)
    ax.plot(verhoff_profile(eta), eta, color="black", linewidth=2.0, label="Verhoff 1963")
    for d in PROFILE_DISTANCES:
        p = outwash_profile(d * R, R, v_i, R)
        ax.plot(p.u / p.peak_speed, p.z / p.half_width, linewidth=1.0, label=f"r = {d:g} R")
    ax.axhspan(0.0, 0.1, color="0.9", zorder=0)
    ax.set_ylim(0.0, 2.5)
    ax.set_xlim(-0.05, 1.1)
    ax.set_xlabel("u / u_max")
    ax.set_ylabel("z / delta")
    ax.set_title("vertical profile, h = R (held to 0.05 above eta = 0.1)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(True, linewidth=0.4, alpha=0.5)


def plot_outwash(path: Path, scene: str = SCENE) -> None:
    """Write the four panels for the scene's helicopter to `path` (PNG)."""
    helicopter = load_scene(scene).helicopter
    v_hover = induced_velocity(helicopter, 1.0, 1e6)
    figure, axes = plt.subplots(2, 2, figsize=(12.0, 8.6))
    _flow_panel(axes[0][0], helicopter, v_hover)
    _jet_panels(axes[0][1], axes[1][0], helicopter, v_hover)
    _profile_panel(axes[1][1], helicopter)
    figure.suptitle(f"brownout downwash: R = {helicopter.rotor_radius:g} m, "
                    f"{helicopter.mass:g} kg, v_h = {v_hover:.2f} m/s", fontsize=10)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


if __name__ == "__main__":
    plot_outwash(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_PATH)
