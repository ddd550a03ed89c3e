"""The adaptation loop: propose, measure the proposal (played on a simulated reality, or
run by a lab on the robot), post the measurement as a ``Trial``, decide; until the method's
stop decision or the measurements run out. The method sees the maps and its trials only,
never the reality."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

from app.adapt import methods as M
from app.adapt.maps import Repertoire
from app.adapt.reality import Measured, Reality, play
from app.adapt.recovered import recovered, target_speed


@dataclasses.dataclass(frozen=True)
class Row:
    """One trial: what was proposed and what the reality measured."""

    trial: int  # 1-based
    proposal: M.Proposal
    cell: int
    measured: Measured
    performance: float  # the method's performance of the measurement (m/s)
    recovered: bool | None  # None: no recovery target for the robot (app/adapt/recovered.py)

    def to_json(self) -> dict:
        m = self.measured
        return {"trial": self.trial, "map": self.proposal.map, "elite": self.proposal.elite, "cell": self.cell,
                "predicted": self.proposal.predicted, "std": self.proposal.std, "forward_m": m.forward_m,
                "lateral_m": m.lateral_m, "yaw_deg": m.yaw_deg, "fell": m.fell, "duration_s": m.duration_s,
                "speed_m_s": m.forward_m / m.duration_s, "performance": self.performance,
                "recovered": self.recovered}


@dataclasses.dataclass(frozen=True)
class Outcome:
    rows: list[Row]
    decision: M.Decision
    target_m_s: float | None

    @property
    def recovered_at(self) -> int | None:
        return next((r.trial for r in self.rows if r.recovered), None)

    def to_json(self, method: str) -> dict:
        d = self.decision
        final = self.rows[d.best_trial].to_json() if d.best_trial is not None else None
        return {"method": method, "trials": [r.to_json() for r in self.rows], "recovered_at": self.recovered_at,
                "target_m_s": self.target_m_s, "stop": {"reason": d.reason, "method_stopped": d.stop,
                                                        "max_predicted": d.max_predicted,
                                                        "best_measured": d.best_measured},
                "final": final}


def run(reps: Sequence[Repertoire], measure: Callable[[Repertoire, M.Proposal], Measured | None], s: M.Settings,
        robot: str | None, on_trial: Callable[[Row], None] | None = None, stored: Any = None) -> Outcome:
    """The loop over any source of measurements: ``measure`` returns the trial's measurement,
    or None when there is none (the lab's input ended): the loop stops there, its decision
    marked as such. ``robot``: whose recovery target rows are checked against (None: none);
    ``stored``: the uploaded robot when ``robot`` is one."""
    by = {r.map.name: r for r in reps}
    maps = [r.map for r in reps]
    trials: list[M.Trial] = []
    rows: list[Row] = []
    target = _target(robot, stored)
    while not (d := M.decide(maps, trials, s)).stop:
        p = M.propose(maps, trials, s)
        rep = by[p.map]
        m = measure(rep, p)
        if m is None:
            d = dataclasses.replace(d, reason=f"measurements ended after {len(trials)} trials, before the method "
                                              f"stopped ({d.reason})")
            break
        t = M.Trial(p.map, p.elite, m.forward_m, m.lateral_m, m.yaw_rad, m.fell, m.duration_s)
        trials.append(t)
        row = Row(len(trials), p, rep.cells[p.elite], m, t.performance(s.straight, s.falls),
                  None if target is None else recovered(m.forward_m, m.fell, m.duration_s, robot, stored))
        rows.append(row)
        if on_trial is not None:
            on_trial(row)
    return Outcome(rows, d, target)


def _target(robot: str | None, stored: Any = None) -> float | None:
    try:
        return target_speed(robot, stored) if robot is not None else None
    except (KeyError, AttributeError):  # an uploaded robot's id without its model: no leg length to scale by
        return None


def adapt(reps: Sequence[Repertoire], reality: Reality, s: M.Settings,
          on_trial: Callable[[Row], None] | None = None) -> Outcome:
    """The loop on a simulated reality: each proposal played on it (app/adapt/reality.py)."""
    return run(reps, lambda rep, p: play(reality, rep, p.elite), s, reality.robot, on_trial, reality.stored)
