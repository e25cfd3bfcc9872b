"""What a run shows of a `straggler` (`nodes/faults.py`): a node whose every frame from its
fault's on takes twice the master's --max-lag longer. It must be named at its first frame
(report.json's `lags`), given up within the lag budget, and the other walls' frame rate must
be back once it is out. The harness then restarts its node without the fault, so that it
joins anew (`joined_frame`) and the run ends with every wall in, as after a `kill`.

The rates come from the harness's clock at the start of each frame (`frame_times`), each the
inverse of the median frame's time (one hitch of a shared machine does not move it): before
the fault (RATE_FRAMES frames), while it straggled, and from the frame after it was given up
to its node's restart. Back means at least RATE_KEPT of the rate before: a straggler holds
the others 10 to 100 times below it, and a load that changes between the two windows, a few
seconds apart, must not make the verdict.
"""

from __future__ import annotations

import statistics

from nodes.faults import RATE_FRAMES, Fault, last_action
from nodes.master.budgets import LAG
from nodes.master.run_record import RunRecord

RATE_KEPT = 0.25


def frames_per_second(times: dict[int, float], first: int, last: int) -> float | None:
    """The rate of frames first to last - 1 by their median time, from when each began
    (None: not timed)."""
    took = [times[k + 1] - times[k] for k in range(first, last)
            if k in times and k + 1 in times]
    if not took:
        return None
    return round(1 / max(statistics.median(took), 1e-9), 2)


def straggler_findings(fault: Fault, record: RunRecord, times: dict[int, float]
                       ) -> tuple[int | None, int | None, dict, str]:
    """(the frame it was first named, the first frame the others' rate was back when every
    verdict held, what the run shows, the outcome in words)."""
    lags = [lag for lag in record.lags if lag.node == fault.node and lag.frame >= fault.frame]
    named = lags[0].frame if lags and lags[0].frame == fault.frame else None
    loss = next((loss for loss in record.losses if loss.node == fault.node
                 and loss.frame >= fault.frame and loss.detected_by == LAG), None)
    restart = last_action(fault)
    joined = next((j.frame for j in record.joins
                   if j.node == fault.node and j.frame >= restart), None)
    budget = next((tally.budget for tally in record.budgets if tally.name == LAG), None)
    rates = {"before": frames_per_second(times, max(fault.frame - RATE_FRAMES, 1), fault.frame)}
    if loss is not None:
        rates |= {"while_straggling": frames_per_second(times, fault.frame, loss.frame + 1),
                  "after_given_up": frames_per_second(times, loss.frame + 1, restart)}
    within = loss is not None and budget is not None and \
        loss.frame - fault.frame <= budget.most
    kept = None not in (rates["before"], rates.get("after_given_up")) and \
        rates["after_given_up"] >= RATE_KEPT * rates["before"]
    detection = {"lags": [lag.to_json() for lag in lags[:10]],
                 "given_up_frame": loss.frame if loss else None,
                 "lag_budget": budget.to_json() if budget else None,
                 "frames_per_second": rates, "restarted_frame": restart,
                 "joined_frame": joined}
    if loss is None:
        return named, None, detection, f"{fault.node} was not given up"
    outcome = (f"{fault.node} lagged from frame {fault.frame} and was given up at frame "
               f"{loss.frame}; the others ran {rates['before']} frames/s before, "
               f"{rates['while_straggling']} while it straggled and "
               f"{rates['after_given_up']} once it was out; restarted, it joined "
               + (f"at frame {joined}" if joined else "after the run's last frame"))
    healed = loss.frame + 1 if named and within and kept else None
    return named, healed, detection, outcome
