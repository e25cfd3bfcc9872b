"""From final states to errors: one `Row` per case, integrator and dt, and one `Summary`
per case and integrator with the observed order next to the table's.

Every error is of positions (m) unless named vel (velocities, m/s) or cloud (the
concentration field, cloud.py: the fraction of the cloud's mass misplaced). Sources, apart:
  gpu        GPU (float32, manual trilinear) against the float64 reference: everything;
  twin       float64 twin against the reference: time stepping alone;
  float32    GPU against the float64 twin of the same method and dt: float32 arithmetic;
  filtering  GPU with hardware filtering against the GPU with manual trilinear;
  portable   GPU with portable arithmetic against the reference, and against the native
             GPU (arithmetic): what the same bits on every GPU cost in accuracy.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from cavesim.tools.numerics.cases import Case
from cavesim.tools.numerics.cloud import CloudGrid, misplaced_fraction
from cavesim.tools.numerics.methods import EXACT_TOLERANCE, FORGOTTEN_TOLERANCE, Method
from cavesim.tools.numerics.order import observed_order, round_off_floor
from cavesim.tools.numerics.reference import Reference
from cavesim.tools.numerics.runs import Run

NAN = float("nan")


def dt_label(dt: float) -> str:
    return f"1/{round(1 / dt)}"


def rms_and_max(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """RMS and maximum over particles of the distance |a - b|."""
    distance = np.linalg.norm(a - b, axis=1)
    return float(np.sqrt(np.mean(distance**2))), float(distance.max())


@dataclass(frozen=True)
class Row:
    case: str
    integrator: str
    dt: float
    dt_label: str
    steps: int
    evaluations: int  # field evaluations per particle to T: steps x the method's per step
    gpu_rms: float
    gpu_max: float
    twin_rms: float
    twin_max: float
    gpu_vel_rms: float  # m/s
    gpu_vel_max: float
    twin_vel_rms: float
    twin_vel_max: float
    gpu_cloud: float  # fraction of the cloud misplaced; NaN where the case has no cloud
    twin_cloud: float
    float32_rms: float
    float32_max: float
    filtering_rms: float  # NaN where hardware filtering was not run
    filtering_max: float
    round_off_floor: float  # m, float64 round-off bound of the twin run (see order.py)
    gpu_step_ms: float  # median wall time of one step
    gpu_ns_per_particle: float  # per step
    gpu_run_s: float  # steps * median step: the GPU's cost of reaching T
    hardware_step_ms: float  # median step with hardware filtering; NaN where not run
    portable_rms: float  # GPU with [simulation] arithmetic = "portable" against the reference
    portable_max: float
    arithmetic_rms: float  # RMS |portable GPU - native GPU|
    portable_step_ms: float  # median step with portable arithmetic

    def to_json(self) -> dict[str, object]:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in asdict(self).items()}


def make_rows(case: Case, method: Method, reference: Reference, gpu: list[Run],
              twin: list[Run], hardware: list[Run] | None, portable: list[Run],
              scale: float) -> list[Row]:
    """The rows of one case and method; `scale` is the RMS size of the final positions."""
    grid = CloudGrid.around(reference.pos) if case.cloud else None
    rows = []
    for k, (g, t, p) in enumerate(zip(gpu, twin, portable, strict=True)):
        ref, ref_vel = reference.position_at(t.end_time), reference.velocity_at(t.end_time)
        gpu_cloud = twin_cloud = NAN
        if grid is not None:
            ref_density = grid.density(ref)
            gpu_cloud = misplaced_fraction(grid, g.pos, ref_density)
            twin_cloud = misplaced_fraction(grid, t.pos, ref_density)
        hw = hardware[k] if hardware else None
        (gpu_rms, gpu_max), (twin_rms, twin_max) = rms_and_max(g.pos, ref), rms_and_max(t.pos, ref)
        (gpu_vel_rms, gpu_vel_max) = rms_and_max(g.vel, ref_vel)
        (twin_vel_rms, twin_vel_max) = rms_and_max(t.vel, ref_vel)
        float32_rms, float32_max = rms_and_max(g.pos, t.pos)
        filtering_rms, filtering_max = rms_and_max(hw.pos, g.pos) if hw else (NAN, NAN)
        portable_rms, portable_max = rms_and_max(p.pos, ref)
        rows.append(Row(
            case=case.name, integrator=method.name, dt=g.dt, dt_label=dt_label(g.dt),
            steps=g.steps, evaluations=g.steps * method.evaluations_for(case.motion),
            gpu_rms=gpu_rms, gpu_max=gpu_max, twin_rms=twin_rms, twin_max=twin_max,
            gpu_vel_rms=gpu_vel_rms, gpu_vel_max=gpu_vel_max, twin_vel_rms=twin_vel_rms,
            twin_vel_max=twin_vel_max, gpu_cloud=gpu_cloud, twin_cloud=twin_cloud,
            float32_rms=float32_rms, float32_max=float32_max, filtering_rms=filtering_rms,
            filtering_max=filtering_max, round_off_floor=round_off_floor(t.steps, scale),
            gpu_step_ms=g.step_seconds * 1e3,
            gpu_ns_per_particle=g.step_seconds / len(g.pos) * 1e9,
            gpu_run_s=g.steps * g.step_seconds,
            hardware_step_ms=hw.step_seconds * 1e3 if hw else NAN,
            portable_rms=portable_rms, portable_max=portable_max,
            arithmetic_rms=rms_and_max(p.pos, g.pos)[0], portable_step_ms=p.step_seconds * 1e3))
    return rows


@dataclass(frozen=True)
class Summary:
    case: str
    integrator: str
    order: int  # theoretical, for the case's motion (a tracer's: its tracer method's)
    expected: float | None  # what the tests hold it to; None: not held to an order
    observed: float  # NaN when too few dts lie above round-off
    fit_dts: tuple[str, ...]
    exact: bool  # the method solves this case exactly
    forgets: bool  # its error dies with the transient here (methods.FORGETS_IN)
    # "ok", "OFF", "exact", "NOT exact", "forgets", "KEEPS" or "-" (case not held to an order)
    verdict: str
    twin_max_error: float  # m, largest twin RMS error over the dts
    evaluations: int  # field evaluations per particle and step
    gpu_rms: float  # at the report dt
    gpu_max: float
    twin_rms: float
    gpu_vel_rms: float  # m/s, at the report dt
    gpu_vel_max: float
    twin_vel_rms: float
    gpu_cloud: float  # at the report dt; NaN where the case has no cloud
    twin_cloud: float
    gpu_step_ms: float
    gpu_ns_per_particle: float
    float32_floor: float  # RMS |GPU - twin| at the finest dt: where float32 dominates
    filtering_rms: float  # at the report dt; NaN where not run
    hardware_step_ms: float  # at the report dt; NaN where not run
    portable_rms: float  # at the report dt
    arithmetic_floor: float  # largest RMS |portable GPU - native GPU| over the dts
    portable_step_ms: float  # at the report dt

    @property
    def portable_cost(self) -> float:
        """How many times longer a portable step takes than a native one (report dt)."""
        return self.portable_step_ms / self.gpu_step_ms

    def to_json(self) -> dict[str, object]:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in {**asdict(self), "portable_cost": self.portable_cost}.items()}


def summarize(case: Case, method: Method, rows: list[Row], report_dt: float) -> Summary:
    fit = observed_order([r.dt for r in rows], [r.twin_rms for r in rows],
                         [r.round_off_floor for r in rows])
    at = min(rows, key=lambda r: abs(r.dt - report_dt))
    finest = min(rows, key=lambda r: r.dt)
    exact, forgets = method.is_exact(case.name), method.forgets(case.name)
    twin_max_error = max(r.twin_rms for r in rows)
    held = case.held_to_order and not exact and not forgets
    expected = method.expected_order(case.order_limit, case.motion) if held else None
    if exact:
        verdict = "exact" if twin_max_error < EXACT_TOLERANCE else "NOT exact"
    elif forgets:
        verdict = "forgets" if twin_max_error < FORGOTTEN_TOLERANCE else "KEEPS"
    elif expected is None:
        verdict = "-"
    else:
        tolerance = method.tolerance if case.order_tolerance is None else case.order_tolerance
        verdict = "ok" if fit.found and abs(fit.order - expected) <= tolerance else "OFF"
    return Summary(
        case=case.name, integrator=method.name, order=method.order_for(case.motion),
        expected=expected,
        observed=fit.order, fit_dts=tuple(dt_label(dt) for dt in fit.dts), exact=exact,
        forgets=forgets, verdict=verdict, twin_max_error=twin_max_error,
        evaluations=method.evaluations_for(case.motion), gpu_rms=at.gpu_rms, gpu_max=at.gpu_max,
        twin_rms=at.twin_rms, gpu_vel_rms=at.gpu_vel_rms, gpu_vel_max=at.gpu_vel_max,
        twin_vel_rms=at.twin_vel_rms, gpu_cloud=at.gpu_cloud, twin_cloud=at.twin_cloud,
        gpu_step_ms=at.gpu_step_ms, gpu_ns_per_particle=at.gpu_ns_per_particle,
        float32_floor=finest.float32_rms, filtering_rms=at.filtering_rms,
        hardware_step_ms=at.hardware_step_ms, portable_rms=at.portable_rms,
        arithmetic_floor=max(r.arithmetic_rms for r in rows),
        portable_step_ms=at.portable_step_ms)
