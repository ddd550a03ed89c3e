"""The evidence protocol, written once (DESIGN.md "Evidence, not just numbers").

Every kind's result carries, beside its answer, the same two blocks, built from the
records here and read by every view through them:

- ``summary["controls"]``: a list of ``ControlRow`` — the baseline, a random search over
  the same space at the same budget, and the method's parts switched off, each with its
  metrics and whether it meets the kind's target;
- ``summary["robustness"]``: a ``Robustness`` block — the answer re-simulated under the
  standard named cases (``CASES``: the timestep halved and quartered, friction, masses,
  payload, rough floor) plus the kind's own, each case judged against the same target;
  numerics (timestep) and physical cases are told apart by ``Case.group``.

Conventions every kind follows:

- the random-search control draws its own stream, ``control_seed(seed)``;
- a job made of several phases (search, control, re-runs) reports progress and keeps
  its checkpoint through ``Phases`` (one entry per phase, one progress bar);
- a kind's target is one ``Target`` (its text and its test), used by the summary, the
  page, the CLI and studies alike.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Literal

from app.jobs.base import Cancelled, RunContext

# -- the control's random stream ------------------------------------------------------------

CONTROL_SEED_OFFSET = 7919  # a prime: the control's stream never starts where the search's does


def control_seed(seed: int) -> int:
    """The seed of the random-search control of a job seeded ``seed``: its own stream,
    reproducible from the job's seed alone."""
    return int(seed) + CONTROL_SEED_OFFSET


# -- the standard robustness cases ----------------------------------------------------------

Group = Literal["numerics", "physical"]


@dataclasses.dataclass(frozen=True)
class Case:
    """A named perturbation of the simulated world. The scales are relative to the kind's
    nominal world; what "mass" or "friction" covers is the kind's (it says so in its label)."""

    name: str
    label: str
    group: Group = "physical"
    timestep_scale: float = 1.0
    friction_scale: float = 1.0
    mass_scale: float = 1.0

    def relabel(self, label: str) -> Case:
        return dataclasses.replace(self, label=label)


CASES: dict[str, Case] = {c.name: c for c in (
    Case("dt_half", "timestep halved", "numerics", timestep_scale=0.5),
    Case("dt_quarter", "timestep quartered", "numerics", timestep_scale=0.25),
    Case("friction_0.7", "friction x 0.7", friction_scale=0.7),
    Case("friction_1.3", "friction x 1.3", friction_scale=1.3),
    Case("mass_+10pct", "every mass +10 %", mass_scale=1.1),
    Case("mass_-10pct", "every mass -10 %", mass_scale=0.9),
    # kind-specific amounts: the kind builds these from its robot (payload mass, floor)
    Case("payload", "payload on the body"),
    Case("rough_terrain", "rough floor"),
)}


def case(name: str, label: str | None = None) -> Case:
    """A standard case by name (KeyError names the known ones), optionally with the
    kind's own label."""
    try:
        c = CASES[name]
    except KeyError:
        raise KeyError(f"unknown robustness case {name!r}; standard: {sorted(CASES)}") from None
    return c.relabel(label) if label is not None else c


def group_of(name: str) -> Group:
    """numerics for the timestep checks, physical for everything else (a kind's own
    cases, such as a ground-estimate error, are physical)."""
    c = CASES.get(name)
    return c.group if c is not None else "physical"


# -- a kind's target ------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Target:
    """What "the method worked" means for a kind: the sentence every page shows and the
    one test every caller applies to a metrics dict."""

    text: str
    test: Callable[[Mapping[str, Any]], bool]

    def met(self, metrics: Mapping[str, Any]) -> bool:
        return bool(self.test(metrics))


# -- typed records of the two shared blocks -------------------------------------------------

def _clean(d: Mapping[str, Any]) -> dict[str, Any]:
    return dict(d)


@dataclasses.dataclass
class ControlRow:
    """One control of ``summary["controls"]``."""

    name: str
    label: str
    metrics: dict[str, Any]
    target_met: bool | None
    evaluations: int
    note: str = ""
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)  # a kind's own keys (e.g. fitness)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, **self.extra, "metrics": _clean(self.metrics),
                "target_met": self.target_met, "evaluations": self.evaluations, "note": self.note}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ControlRow:
        known = {"name", "label", "metrics", "target_met", "evaluations", "note"}
        return cls(name=d["name"], label=d.get("label", d["name"]), metrics=dict(d.get("metrics") or {}),
                   target_met=d.get("target_met"), evaluations=int(d.get("evaluations") or 0),
                   note=d.get("note") or "", extra={k: v for k, v in d.items() if k not in known})


@dataclasses.dataclass
class CaseResult:
    """One re-simulation of the answer under a named case."""

    name: str
    label: str
    metrics: dict[str, Any]
    target_met: bool | None
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def group(self) -> Group:
        return group_of(self.name)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, **self.extra, "metrics": _clean(self.metrics),
                "target_met": self.target_met}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> CaseResult:
        known = {"name", "label", "metrics", "target_met"}
        return cls(name=d["name"], label=d.get("label", d["name"]), metrics=dict(d.get("metrics") or {}),
                   target_met=d.get("target_met"), extra={k: v for k, v in d.items() if k not in known})


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def spread(nominal: Mapping[str, Any], cases: Iterable[Mapping[str, Any]], keys: Sequence[str] | None = None,
           as_float: bool = True) -> dict[str, dict[str, Any]]:
    """Per metric, the range over the nominal answer and every case: {"min", "max",
    "nominal"}. ``keys``: the metrics to cover (default: the nominal's numeric ones); a
    metric with no number anywhere is left out. ``as_float`` writes floats (else each
    value as it is, so counts stay integers)."""
    metrics = [c["metrics"] for c in cases]
    keys = [k for k, v in nominal.items() if _number(v)] if keys is None else list(keys)
    out = {}
    for k in keys:
        vals = [m[k] for m in metrics if _number(m.get(k))]
        nom = nominal.get(k)
        allv = vals + ([nom] if _number(nom) else [])
        if not allv:
            continue
        conv = float if as_float else (lambda v: v)
        out[k] = {"min": conv(min(allv)), "max": conv(max(allv)), "nominal": conv(nom) if _number(nom) else None}
    return out


@dataclasses.dataclass
class Robustness:
    """``summary["robustness"]``: the answer under every case, judged by the target."""

    target: str
    cases: list[CaseResult]
    spread: dict[str, dict[str, Any]]
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def met(self) -> int:
        return sum(1 for c in self.cases if c.target_met is True)

    @property
    def total(self) -> int:
        return len(self.cases)

    def count(self, group: Group) -> tuple[int, int]:
        """(met, total) over the cases of one group."""
        cs = [c for c in self.cases if c.group == group]
        return sum(1 for c in cs if c.target_met is True), len(cs)

    def to_json(self) -> dict[str, Any]:
        return {"target": self.target, "cases": [c.to_json() for c in self.cases], "met": self.met,
                "total": self.total, "spread": self.spread, **self.extra}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> Robustness:
        known = {"target", "cases", "met", "total", "spread"}
        return cls(target=d.get("target", ""), cases=[CaseResult.from_json(c) for c in d.get("cases") or []],
                   spread=dict(d.get("spread") or {}), extra={k: v for k, v in d.items() if k not in known})

    @classmethod
    def build(cls, target: str, nominal_metrics: Mapping[str, Any], cases: Sequence[Mapping[str, Any]],
              keys: Sequence[str] | None = None, as_float: bool = True, **extra: Any) -> Robustness:
        """From the case dicts a kind's re-simulations produced: {"name", "label",
        "metrics", "target_met", ...}."""
        return cls(target=target, cases=[CaseResult.from_json(c) for c in cases],
                   spread=spread(nominal_metrics, cases, keys, as_float), extra=dict(extra))


def controls_of(summary: Mapping[str, Any]) -> list[ControlRow]:
    return [ControlRow.from_json(c) for c in summary.get("controls") or []]


def robustness_of(summary: Mapping[str, Any]) -> Robustness | None:
    r = summary.get("robustness")
    return Robustness.from_json(r) if isinstance(r, Mapping) and "cases" in r else None


# -- the phases of one job ------------------------------------------------------------------

class Phases:
    """The phases of one job (a search, its equal-budget random-search control, the
    robustness re-runs ...), each with its own checkpoint entry and its own share of the
    progress bar, in budget units (usually evaluations).

        phases = Phases(ctx, {"search": P * (G + 1), "random_search": P * (G + 1), "robustness": 7})
        out = run_search(opt, evaluate, G, phases.context("search"), ...)
        rob = phases.context("robustness"); ...; rob.tick()

    The job's checkpoint is {phase name: that phase's checkpoint}; a phase resumed after a
    kill finds its own entry; a finished phase's entry may hold its result."""

    def __init__(self, ctx: RunContext, sizes: Mapping[str, int]):
        self.ctx = ctx
        self.sizes = dict(sizes)
        self.state: dict[str, Any] = ctx.load_checkpoint() or {}
        self.artifact_dir = getattr(ctx, "artifact_dir", None)

    def context(self, name: str) -> PhaseContext:
        offset = 0
        for n, size in self.sizes.items():
            if n == name:
                return PhaseContext(self, name, offset, size)
            offset += size
        raise KeyError(f"unknown phase {name!r}; phases: {list(self.sizes)}")

    @property
    def total(self) -> int:
        return max(1, sum(self.sizes.values()))

    def finish(self) -> None:
        self.ctx.progress(self.total, self.total, {"phase": "done"})


class PhaseContext:
    """A run context for one phase: checkpoints land in the job's checkpoint under the
    phase's name; progress is scaled into the phase's share of the job's total. Besides
    the ``RunContext`` methods (what ``run_search`` needs), ``tick`` counts units done by
    a phase that is not a search, and ``check`` raises ``Cancelled`` when asked to stop."""

    def __init__(self, phases: Phases, name: str, offset: int, size: int):
        self._phases, self.name, self._offset, self._size = phases, name, offset, size
        self.artifact_dir = phases.artifact_dir
        self.done = 0

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        share = round(self._size * done / total) if total else 0
        self._phases.ctx.progress(self._offset + share, self._phases.total, {"phase": self.name} | info)

    def tick(self, n: int = 1, info: dict[str, Any] | None = None) -> None:
        """``n`` more units of this phase done: report them, then stop if cancelled."""
        self.done = min(self._size, self.done + int(n))
        self._phases.ctx.progress(self._offset + self.done, self._phases.total, {"phase": self.name, **(info or {})})
        self.check()

    def check(self) -> None:
        if self._phases.ctx.is_cancelled():
            raise Cancelled()

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        self._phases.state[self.name] = state
        self._phases.ctx.save_checkpoint(self._phases.state)

    def load_checkpoint(self) -> dict[str, Any] | None:
        return self._phases.state.get(self.name)

    def is_cancelled(self) -> bool:
        return self._phases.ctx.is_cancelled()
