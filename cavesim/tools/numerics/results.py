"""From final positions to errors: one `Row` per case, integrator and dt, and one `Summary`
per case and integrator with the observed order next to the table's.

Error sources, kept apart:
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
from cavesim.tools.numerics.methods import EXACT_TOLERANCE, Method
from cavesim.tools.numerics.order import observed_order, round_off_floor
from cavesim.tools.numerics.reference import Reference
from cavesim.tools.numerics.runs import Run

NAN = float("nan")


def dt_label(dt: float) -> str:
    return f"1/{round(1 / dt)}"


def rms_and_max(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """RMS and maximum over particles of the distance |a - b| (m)."""
    distance = np.linalg.norm(a - b, axis=1)
    return float(np.sqrt(np.mean(distance**2))), float(distance.max())


@dataclass(frozen=True)
class Row:
    case: str
    integrator: str
    dt: float
    dt_label: str
    steps: int
    gpu_rms: float
    gpu_max: float
    twin_rms: float
    twin_max: float
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
    rows = []
    for k, (g, t, p) in enumerate(zip(gpu, twin, portable, strict=True)):
        ref = reference.position_at(t.end_time)
        hw = rms_and_max(hardware[k].pos, g.pos) if hardware else (NAN, NAN)
        rows.append(Row(case.name, method.name, g.dt, dt_label(g.dt), g.steps,
                        *rms_and_max(g.pos, ref), *rms_and_max(t.pos, ref),
                        *rms_and_max(g.pos, t.pos), *hw, round_off_floor(t.steps, scale),
                        g.step_seconds * 1e3, g.step_seconds / len(g.pos) * 1e9,
                        g.steps * g.step_seconds,
                        hardware[k].step_seconds * 1e3 if hardware else NAN,
                        *rms_and_max(p.pos, ref), rms_and_max(p.pos, g.pos)[0],
                        p.step_seconds * 1e3))
    return rows


@dataclass(frozen=True)
class Summary:
    case: str
    integrator: str
    order: int  # theoretical
    expected: float | None  # what the tests hold it to; None: not held (case not smooth)
    observed: float  # NaN when too few dts lie above round-off
    fit_dts: tuple[str, ...]
    exact: bool  # the method solves this case exactly
    verdict: str  # "ok", "OFF", "exact", "NOT exact" or "-" (not held to an order)
    twin_max_error: float  # m, largest twin RMS error over the dts
    gpu_rms: float  # at the report dt
    gpu_max: float
    twin_rms: float
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
    exact = method.is_exact(case.name)
    twin_max_error = max(r.twin_rms for r in rows)
    expected = method.expected_order(case.order_limit) if case.smooth and not exact else None
    if exact:
        verdict = "exact" if twin_max_error < EXACT_TOLERANCE else "NOT exact"
    elif expected is None:
        verdict = "-"
    else:
        verdict = "ok" if fit.found and abs(fit.order - expected) <= method.tolerance else "OFF"
    return Summary(case.name, method.name, method.order, expected, fit.order,
                   tuple(dt_label(dt) for dt in fit.dts), exact, verdict, twin_max_error,
                   at.gpu_rms, at.gpu_max, at.twin_rms, at.gpu_step_ms, at.gpu_ns_per_particle,
                   finest.float32_rms, at.filtering_rms, at.hardware_step_ms, at.portable_rms,
                   max(r.arithmetic_rms for r in rows), at.portable_step_ms)

