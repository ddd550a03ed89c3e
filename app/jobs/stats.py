"""Statistics a referee expects (issue 28), shared by every kind's experiments.

- ``paired``: a method against a control on the same seeds (or fields, or cases): the
  paired differences oriented so that a positive difference means the method is better,
  their mean with a confidence interval, the test named, the seed count and the effect
  size. The interval: Student's t on the differences below 10 pairs (a bootstrap of so few
  values is too narrow), scipy's BCa bootstrap from 10 on. The test: Wilcoxon's
  signed-rank, two-sided, exact where scipy can be (no ties, no zeros). The verdict follows
  the interval alone: one that includes zero is "not shown", never a finding either way.
- ``detectable``: the smallest true mean difference that a paired two-sided t-test at
  level alpha finds with the given power, from the observed spread and the pair count:
  what a null result can and cannot exclude (the power statement of a "not shown").
- ``success_rate``: a success count with its Clopper-Pearson interval
  (``scipy.stats.binomtest(...).proportion_ci(method="exact")``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

CONFIDENCE = 0.95
BOOTSTRAP_FROM = 10  # pairs; below this the t interval
NOT_SHOWN = "not shown"


def verdict(ci: Sequence[float] | None, names: tuple[str, str] = ("method", "control")) -> str:
    """"not shown" unless the whole interval lies on one side of zero; else which side is
    better, shown."""
    if ci is None or ci[0] is None or ci[1] is None:
        return NOT_SHOWN
    if ci[0] > 0:
        return f"{names[0]} better (shown)"
    if ci[1] < 0:
        return f"{names[1]} better (shown)"
    return NOT_SHOWN


def _interval(d: np.ndarray, confidence: float, seed: int) -> tuple[list[float] | None, str]:
    from scipy import stats

    n = len(d)
    if n < 2:
        return None, "none (fewer than 2 pairs)"
    sd = float(d.std(ddof=1))
    if sd == 0.0:
        return [float(d.mean())] * 2, "none needed (every difference equal)"
    if n < BOOTSTRAP_FROM:
        lo, hi = stats.t.interval(confidence, n - 1, loc=float(d.mean()), scale=sd / math.sqrt(n))
        return [float(lo), float(hi)], f"Student t on the {n} paired differences"
    r = stats.bootstrap((d,), np.mean, confidence_level=confidence, n_resamples=9999, method="BCa",
                        rng=np.random.default_rng(seed))
    return [float(r.confidence_interval.low), float(r.confidence_interval.high)], \
        "BCa bootstrap of the mean difference, 9999 resamples (scipy.stats.bootstrap)"


def _wilcoxon(d: np.ndarray) -> tuple[float | None, str, float | None]:
    """(p, test name, the smallest p the exact test can give with these pairs)."""
    from scipy import stats

    nz = d[d != 0]
    if len(nz) == 0:
        return 1.0, "Wilcoxon signed-rank, two-sided (every difference zero)", None
    exact = len(np.unique(np.abs(nz))) == len(nz) and len(nz) <= 50
    r = stats.wilcoxon(nz, alternative="two-sided", method="exact" if exact else "approx")
    name = "Wilcoxon signed-rank, two-sided, " + ("exact" if exact else "normal approximation") + " (scipy.stats.wilcoxon)"
    return float(r.pvalue), name, (2.0 / 2 ** len(nz) if exact else None)


def paired(method: Sequence[float], control: Sequence[float], higher_is_better: bool = True,
           confidence: float = CONFIDENCE, seed: int = 0, names: tuple[str, str] = ("method", "control")) -> dict[str, Any]:
    """The method against the control, pair by pair (same seed, field or case in both);
    ``names`` word the verdict."""
    a, b = np.asarray(method, float), np.asarray(control, float)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"paired values must be two 1-D sequences of one length; got {a.shape} and {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("paired values must be finite (drop a pair that has no value on either side)")
    d = a - b if higher_is_better else b - a
    n = len(d)
    ci, ci_method = _interval(d, confidence, seed)
    p, test, min_p = _wilcoxon(d) if n else (None, "none", None)
    sd = float(d.std(ddof=1)) if n > 1 else None
    dz = None if not sd else float(d.mean()) / sd
    return {"n": n, "better": "higher" if higher_is_better else "lower",
            "method_mean": float(a.mean()) if n else None, "control_mean": float(b.mean()) if n else None,
            "differences": [float(x) for x in d], "mean_diff": float(d.mean()) if n else None,
            "median_diff": float(np.median(d)) if n else None, "sd_diff": sd,
            "confidence": confidence, "ci": ci, "ci_method": ci_method, "test": test, "p": p, "min_p": min_p,
            "effect_size": dz, "effect_size_name": "Cohen's d_z (mean / sd of the paired differences)",
            "verdict": verdict(ci, names)}


def detectable(sd: float, n: int, alpha: float = 0.05, power: float = 0.8) -> float | None:
    """Smallest true mean paired difference a two-sided paired t-test at ``alpha`` detects
    with probability ``power``, for ``n`` pairs whose differences have standard deviation
    ``sd`` (noncentral t, scipy). None below 2 pairs."""
    from scipy import optimize, stats

    if n < 2 or sd is None:
        return None
    if sd == 0:
        return 0.0
    df = n - 1
    tc = stats.t.ppf(1 - alpha / 2, df)

    def pw(delta: float) -> float:
        nc = delta / (sd / math.sqrt(n))
        p = float(stats.nct.sf(tc, df, nc) + stats.nct.cdf(-tc, df, nc))
        return (1.0 if p != p else min(p, 1.0)) - power  # nct's tail is NaN where the power is 1

    hi = sd
    while pw(hi) < 0:
        hi *= 2
    return float(optimize.brentq(pw, 0.0, hi, xtol=1e-9 * sd))


def pairs_needed(effect: float, sd: float, alpha: float = 0.05, power: float = 0.8, most: int = 10_000) -> int | None:
    """How many pairs a two-sided paired t-test at ``alpha`` needs to find a true mean
    difference ``effect`` with probability ``power`` when the differences spread ``sd``
    (None: more than ``most``, or no effect)."""
    if not effect or sd is None:
        return None
    ok = lambda n: detectable(sd, n, alpha, power) <= abs(effect)  # noqa: E731 (falls as n grows)
    lo, hi = 1, 2
    while not ok(hi):
        lo, hi = hi, hi * 2
        if hi > most:
            return None
    while hi - lo > 1:  # bisection: ok(hi), not ok(lo)
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def success_rate(k: int, n: int, confidence: float = CONFIDENCE) -> dict[str, Any]:
    """k successes of n with the exact (Clopper-Pearson) interval."""
    from scipy import stats

    if n <= 0:
        return {"k": k, "n": n, "rate": None, "ci": None, "ci_method": "none (no trials)"}
    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return {"k": int(k), "n": int(n), "rate": k / n, "ci": [float(ci.low), float(ci.high)], "confidence": confidence,
            "ci_method": "Clopper-Pearson exact (scipy.stats.binomtest)"}


# -- words ----------------------------------------------------------------------------------

def _s(v: float | None, digits: int, sign: bool = True) -> str:
    if v is None:
        return "-"
    return f"{v:+.{digits}f}" if sign else f"{v:.{digits}f}"


def paired_text(r: dict[str, Any], unit: str = "", digits: int = 2) -> str:
    """One line: mean difference [interval], effect size, test and p, pairs: verdict."""
    u = f" {unit}" if unit else ""
    ci = "no interval" if r["ci"] is None else f"[{_s(r['ci'][0], digits)}, {_s(r['ci'][1], digits)}]"
    dz = "-" if r["effect_size"] is None else f"{r['effect_size']:.2f}"
    p = "-" if r["p"] is None else f"{r['p']:.3g}"
    return (f"{_s(r['mean_diff'], digits)}{u} {ci} ({round(100 * r['confidence'])} %), d_z = {dz}, "
            f"Wilcoxon p = {p}, n = {r['n']}: **{r['verdict']}**")


def rate_text(r: dict[str, Any], digits: int = 2) -> str:
    if r["rate"] is None:
        return f"{r['k']}/{r['n']}"
    return f"{r['k']}/{r['n']} = {r['rate']:.{digits}f} [{r['ci'][0]:.{digits}f}, {r['ci'][1]:.{digits}f}]"


PAIRED_NOTE = ("Paired differences are oriented so that a positive one favours the method; the interval is "
               f"{round(100 * CONFIDENCE)} % (Student t below {BOOTSTRAP_FROM} pairs, BCa bootstrap from "
               f"{BOOTSTRAP_FROM}, scipy); the test is Wilcoxon's signed-rank (two-sided); d_z is Cohen's effect size "
               "of paired data (mean / sd of the differences). A difference whose interval includes zero is "
               "**not shown**, never a finding either way.")
