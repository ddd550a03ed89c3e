"""How the next gait is chosen and when to stop: Intelligent Trial and Error as published,
and gaitmend's multi-prior variant, each a pure function of the maps and the trials.

ITE (Cully, Clune, Tarapore, Mouret, Nature 521, 2015; Methods and the authors' limbo
experiment): one map; the model is ``model.posterior`` (Matern 5/2, rho 0.4, noise 0.001);
the next gait is the elite maximising the upper confidence bound mu + kappa sigma with
kappa 0.05; the search stops when the best measured performance reaches alpha = 0.9 of the
highest predicted performance over the map, or after 20 trials. Performance is the forward
speed of the trial (m/s), the map's as well as the robot's, so a map scored over a trial of
another length is on the same scale.

gaitmend's variant (``MultiPrior``) changes five things, each switchable for the ablations, and takes a
sixth when the lab states it (``target_m_s``):
- ``priors``: several maps (e.g. built for the intact robot and for stated damages); each
  is scored by the log marginal likelihood of the trials under its Gaussian process, and the
  next gait is proposed from the map that explains the trials best (the idea of Reset-free
  Trial and Error and APROL);
- ``straight``: performance is forward speed less the lateral speed (|drift| / duration), on
  the maps as on the robot, so the gait chosen also walks straight;
- ``falls``: a trial that fell counts as performance 0 whatever it measured (the gait is no
  answer), and the Gaussian process carries that to its neighbours;
- ``walks_to_stop`` (the stop rule's guard): the alpha rule may stop only on a measured trial
  whose performance is above 0. ITE's rule as published compares the best measured with
  alpha x the best predicted whatever their sign, so when every prediction is <= 0 (a map
  of a robot that cannot walk forward, or trials that pulled the posterior down) a trial
  that measured 0 (stood still, or fell under ``falls``) meets 0 >= alpha x (a number <= 0)
  and the search ends at once on a gait that does not walk. With the guard the search goes
  on until a trial walks forward at alpha x the best prediction or the trials are spent.
  Neither rule stops before a trial was measured;
- ``no_repeat``: the next gait is never one already tried (on a simulated reality a repeat
  measures the same again; ITE may propose it again);
- ``target_m_s`` (off unless the lab states it, e.g. the recovery target of
  app/adapt/recovered.py): the search stops at the first trial that walks forward at least
  that fast without falling, and only then or after the trial budget; the alpha rule does
  not stop it (it may be met by a gait slower than the lab needs).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from app.adapt.model import GPSettings, posterior


@dataclasses.dataclass(frozen=True)
class Map:
    """One prior: a repertoire's elites. ``descriptors`` (N, d) in [0, 1]; ``forward_m`` and
    ``lateral_m`` (N,) what each elite walked in the map's trial of ``trial_s`` seconds."""

    name: str
    descriptors: np.ndarray
    forward_m: np.ndarray
    lateral_m: np.ndarray
    trial_s: float

    def performance(self, straight: bool) -> np.ndarray:
        p = np.asarray(self.forward_m, float) - (np.abs(np.asarray(self.lateral_m, float)) if straight else 0.0)
        return p / self.trial_s


@dataclasses.dataclass(frozen=True)
class Trial:
    """One measured trial of elite ``elite`` of map ``map`` on the robot."""

    map: str
    elite: int
    forward_m: float
    lateral_m: float
    yaw_rad: float
    fell: bool
    duration_s: float

    def performance(self, straight: bool, falls: bool) -> float:
        if falls and self.fell:
            return 0.0
        return (self.forward_m - (abs(self.lateral_m) if straight else 0.0)) / self.duration_s


@dataclasses.dataclass(frozen=True)
class Settings:
    kappa: float = 0.05  # UCB exploration weight
    alpha: float = 0.9  # stop when the best measured reaches alpha x the best predicted
    max_trials: int = 20
    gp: GPSettings = GPSettings()
    priors: bool = False  # several maps, chosen by likelihood (ITE: one map)
    straight: bool = False
    falls: bool = False
    walks_to_stop: bool = False  # the alpha rule stops only on a trial with performance > 0 (ITE: off)
    no_repeat: bool = False  # never propose an elite already tried
    target_m_s: float | None = None  # stop at the first trial at this forward speed without a fall (module doc)


ITE = Settings()
GAITMEND = Settings(priors=True, straight=True, falls=True, walks_to_stop=True, no_repeat=True)


@dataclasses.dataclass(frozen=True)
class Proposal:
    map: str
    elite: int
    predicted: float  # mu at the elite (m/s of the method's performance)
    std: float
    acquisition: float
    prior: float  # the map's own value there
    log_likelihood: dict[str, float]  # per map: how well it explains the trials


def _by_name(maps: Sequence[Map]) -> dict[str, Map]:
    out = {m.name: m for m in maps}
    if not maps or len(out) != len(maps):
        raise ValueError("adaptation needs at least one map, each with its own name")
    if len({m.descriptors.shape[1] for m in maps}) != 1:
        raise ValueError("the maps' behaviour descriptors differ in dimension")
    return out


def _located(maps: dict[str, Map], trials: Sequence[Trial]) -> np.ndarray:
    """The behaviour descriptor of each trial's elite, (t, d)."""
    d = next(iter(maps.values())).descriptors.shape[1]
    return np.array([maps[t.map].descriptors[t.elite] for t in trials], dtype=float).reshape(len(trials), d)


def _prior_at(m: Map, x: np.ndarray, perf: np.ndarray) -> np.ndarray:
    """The map's performance at descriptors ``x`` (t, d): its nearest elite's."""
    if len(x) == 0:
        return np.zeros(0)
    d2 = ((x[:, None, :] - m.descriptors[None, :, :]) ** 2).sum(-1)
    return perf[np.argmin(d2, axis=1)]


def _posteriors(maps: Sequence[Map], trials: Sequence[Trial], s: Settings):
    by = _by_name(maps)
    x = _located(by, trials)
    y = np.array([t.performance(s.straight, s.falls) for t in trials], dtype=float)
    out = {}
    for m in (maps if s.priors else maps[:1]):
        perf = m.performance(s.straight)
        at = np.array([perf[t.elite] if t.map == m.name else _prior_at(m, x[k:k + 1], perf)[0]
                       for k, t in enumerate(trials)], dtype=float)
        out[m.name] = (m, perf, posterior(m.descriptors, perf, x, at, y, s.gp))
    return out, y


def propose(maps: Sequence[Map], trials: Sequence[Trial], s: Settings = ITE) -> Proposal:
    """The next gait: the elite of the best-explaining map (the first map when ``priors``
    is off, as ITE) with the highest mu + kappa sigma (first index on a tie)."""
    posts, _ = _posteriors(maps, trials, s)
    ll = {name: p.log_likelihood for name, (_, _, p) in posts.items()}
    name = max(ll, key=lambda k: (ll[k], -list(ll).index(k)))
    m, perf, p = posts[name]
    acq = p.mean + s.kappa * p.std
    if s.no_repeat:
        tried = [t.elite for t in trials if t.map == name]
        if len(tried) < len(acq):
            acq = acq.copy()
            acq[tried] = -np.inf
    i = int(np.argmax(acq))
    return Proposal(name, i, float(p.mean[i]), float(p.std[i]), float(acq[i]), float(perf[i]), ll)


@dataclasses.dataclass(frozen=True)
class Decision:
    stop: bool
    reason: str
    best_trial: int | None  # index into the trials of the best measured one
    best_measured: float | None
    max_predicted: float


def decide(maps: Sequence[Map], trials: Sequence[Trial], s: Settings = ITE) -> Decision:
    """ITE's stop rule: the best measured performance reaches alpha of the highest
    predicted over the chosen map, or the trial budget is spent; never before a trial was
    measured. With ``walks_to_stop`` the alpha rule needs the best measured above 0 too
    (module doc: as published it stops on a gait that does not walk once every prediction
    is <= 0)."""
    posts, y = _posteriors(maps, trials, s)
    ll = {name: p.log_likelihood for name, (_, _, p) in posts.items()}
    name = max(ll, key=lambda k: (ll[k], -list(ll).index(k)))
    top = float(np.max(posts[name][2].mean))
    if not trials:
        return Decision(False, "no trial yet", None, None, top)
    k = int(np.argmax(y))
    best = float(y[k])
    if s.target_m_s is not None:
        hit = next((j for j, t in enumerate(trials)
                    if not t.fell and t.duration_s > 0 and t.forward_m / t.duration_s >= s.target_m_s), None)
        if hit is not None:
            return Decision(True, f"trial {hit + 1} walks at {trials[hit].forward_m / trials[hit].duration_s:.3f} m/s "
                                  f"without a fall, at least the target {s.target_m_s:g}", hit,
                            float(y[hit]), top)
        if len(trials) >= s.max_trials:
            return Decision(True, f"{s.max_trials} trials spent, none at the target {s.target_m_s:g} m/s; the best "
                                  f"was trial {k + 1} ({best:.3f})", k, best, top)
        return Decision(False, f"no trial at the target {s.target_m_s:g} m/s yet", k, best, top)
    if best >= s.alpha * top and (best > 0 or not s.walks_to_stop):
        return Decision(True, f"trial {k + 1} measured {best:.3f}, at least {s.alpha:g} x the best predicted "
                              f"{top:.3f}", k, best, top)
    if len(trials) >= s.max_trials:
        return Decision(True, f"{s.max_trials} trials spent; the best was trial {k + 1} ({best:.3f})", k, best, top)
    if best >= s.alpha * top:  # only with walks_to_stop
        return Decision(False, f"best measured {best:.3f} reaches {s.alpha:g} x the best predicted {top:.3f} but "
                               "does not walk forward (performance <= 0): going on", k, best, top)
    return Decision(False, f"best measured {best:.3f} is below {s.alpha:g} x the best predicted {top:.3f}", k, best,
                    top)
