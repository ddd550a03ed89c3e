"""The typed records of the evidence protocol (app/jobs/evidence.py tells the whole
protocol): the standard robustness cases, a kind's ``Target``, and the records of the two
shared summary blocks (``ControlRow``, ``CaseResult``, ``Robustness``, and the held-out
random models a robustness block may carry, ``HeldOut``) with their readers.
They import nothing of the kind contract, so the contract's own defaults (the verdict,
app/jobs/verdict.py) can read them; app/jobs/evidence.py re-exports every name."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Literal

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


@dataclasses.dataclass(frozen=True)
class HeldOut:
    """``summary["robustness"]["held_out"]``: the answer on random models drawn from stated
    ranges with a stream no search drew from, the figure that says how the answer does on
    models it was not searched on. Read from {"n", "met", "models": [{"metrics": {"fell"},
    "target_met"}], "fell"?, "ranges_text"?}: ``judged`` the models the target judged (a
    walk too short to judge leaves only falls judged), ``fell`` the models that fell (the
    block's own count, else counted from its models' ``fell`` metric, else None)."""

    n: int
    met: int
    judged: int
    fell: int | None
    ranges: str = ""

    @property
    def share(self) -> float | None:
        return self.met / self.judged if self.judged else None

    @property
    def fall_share(self) -> float | None:
        return self.fell / self.n if self.fell is not None and self.n else None

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> HeldOut | None:
        n = d.get("n")
        if not isinstance(n, int) or isinstance(n, bool) or n <= 0:
            return None
        models = [m for m in d.get("models") or [] if isinstance(m, Mapping)]
        met = d.get("met") if isinstance(d.get("met"), int) else sum(m.get("target_met") is True for m in models)
        judged = sum(m.get("target_met") is not None for m in models) if models else n
        fell = d.get("fell")
        if not isinstance(fell, int) or isinstance(fell, bool):
            flags = [(m.get("metrics") or {}).get("fell") for m in models]
            fell = sum(bool(f) for f in flags) if models and all(isinstance(f, bool) for f in flags) else None
        return cls(n=n, met=int(met), judged=judged, fell=fell, ranges=str(d.get("ranges_text") or ""))


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

    @property
    def held_out(self) -> HeldOut | None:
        """The held-out random models, when the block carries them (any kind may)."""
        h = self.extra.get("held_out")
        return HeldOut.from_json(h) if isinstance(h, Mapping) else None

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
