"""Statistics a referee expects (issue 28), shared by every kind's experiments.

- ``paired``: a method against a control on the same seeds (or fields, or cases): the
  paired differences oriented so that a positive difference means the method is better,
  their mean with a confidence interval, the test named, the seed count and the effect
  size. The interval: Student's t on the differences below 10 pairs (a bootstrap of so few
  values is too narrow), scipy's BCa bootstrap from 10 on. The test: Wilcoxon's
  signed-rank, two-sided, zero differences dropped, exact where it can be (scipy's exact
  distribution without ties; with ties, all 2^n sign flips up to 16 pairs), the normal
  approximation beyond. The verdict needs both: a difference is "shown" only when the
  interval excludes zero AND the test rejects at the same level (p < 1 - confidence); else
  it is "not shown", never a finding either way, with the reason in words when the two
  disagree (e.g. 4 pairs: the t interval may exclude zero while the exact test cannot give
  p below 2/2^4 = 0.125).
- ``detectable``: the smallest true mean difference that a paired two-sided t-test at
  level alpha finds with the given power, from the observed spread and the pair count:
  what a null result can and cannot exclude (the power statement of a "not shown").
- ``pairs_needed``: the pairs that ``detectable`` says find a given difference, never fewer
  than ``fewest_pairs`` (the signed-rank test cannot reject with fewer).
- ``success_rate``: a success count with its Clopper-Pearson interval
  (``scipy.stats.binomtest(...).proportion_ci(method="exact")``).
- ``wilson``: the Wilson score interval of a share k/n (the recovery pages' held-out
  shares and the verdict's held-out figure, app/jobs/verdict.py).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

CONFIDENCE = 0.95
BOOTSTRAP_FROM = 10  # pairs; below this the t interval
EXACT_UP_TO = 50  # non-zero pairs; without ties, scipy's exact signed-rank distribution up to this many
TIES_EXACT_UP_TO = 16  # with ties, the exact signed-rank test over all 2^n sign flips up to this many
NOT_SHOWN = "not shown"


def alpha_of(confidence: float = CONFIDENCE) -> float:
    """The test's level that goes with a ``confidence`` interval (0.95 -> 0.05, rounded so
    that 1 - 0.95 is 0.05)."""
    return round(1.0 - confidence, 12)


def fewest_pairs(confidence: float = CONFIDENCE) -> int:
    """The fewest pairs whose exact two-sided signed-rank test can reject at the level that
    goes with ``confidence``: its smallest p with n pairs (no ties, no zeros) is 2 / 2**n."""
    n = 1
    while 2.0 / 2 ** n >= alpha_of(confidence):
        n += 1
    return n


def decision(ci: Sequence[float] | None, p: float | None, min_p: float | None = None,
             confidence: float = CONFIDENCE, test: str = "Wilcoxon", interval: str | None = None,
             n: int | None = None) -> tuple[int, str]:
    """(+1: the method shown better, -1: the control shown better, 0: not shown; why, in
    words). Shown only when the interval lies on one side of zero AND the test's ``p`` is
    below 1 - ``confidence``; ``min_p``: the smallest p the test can give with these pairs;
    ``interval``: what the words call the interval (default "95 % interval"); ``n``: the
    pair count, to say when the test's pairs are fewer (zero differences dropped)."""
    alpha = alpha_of(confidence)
    has_ci = ci is not None and ci[0] is not None and ci[1] is not None
    side = (1 if ci[0] > 0 else -1 if ci[1] < 0 else 0) if has_ci else 0
    rejects = p is not None and p < alpha
    conf = interval or f"{round(100 * confidence)} % interval"
    if side and rejects:
        return side, f"the {conf} excludes 0 and {test} p = {p:.3g} < {alpha:g}"
    if side and p is None:
        return 0, f"the {conf} excludes 0, but there is no test"
    if side and min_p is not None and min_p >= alpha:
        k = round(math.log2(2.0 / min_p))
        pairs = f"{k} pairs" if n is None or n == k else f"{k} non-zero pairs"
        return 0, f"the {conf} excludes 0, but {pairs} cannot give {test} p < {alpha:g}"
    if side:
        return 0, f"the {conf} excludes 0, but {test} p = {p:.3g} >= {alpha:g}"
    if rejects:
        return 0, f"{test} p = {p:.3g} < {alpha:g}, but the {conf} includes 0"
    return 0, f"the {conf} includes 0" if has_ci else "no interval"


def verdict(ci: Sequence[float] | None, p: float | None, min_p: float | None = None,
            names: tuple[str, str] = ("method", "control"), confidence: float = CONFIDENCE,
            n: int | None = None) -> str:
    """"<name> better (shown)" when ``decision`` shows a side; else "not shown", followed by
    the reason in brackets when the interval and the test disagree (the interval excludes 0
    but the test does not reject, or the other way round)."""
    side, why = decision(ci, p, min_p, confidence, interval="interval", n=n)
    if side:
        return f"{names[0] if side > 0 else names[1]} better (shown)"
    has_ci = ci is not None and ci[0] is not None and ci[1] is not None
    excludes = has_ci and (ci[0] > 0 or ci[1] < 0)
    rejects = p is not None and p < alpha_of(confidence)
    return f"{NOT_SHOWN} ({why.removeprefix('the ')})" if excludes or rejects else NOT_SHOWN


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


def _signflip_p(nz: np.ndarray) -> float:
    """The exact two-sided signed-rank p of non-zero differences with ties: the sum of the
    positive differences' mid-ranks against its distribution over all 2^n sign flips (each
    equally likely under the null); symmetric, so as extreme = as far from its mean."""
    from scipy.stats import rankdata

    r2 = np.rint(2 * rankdata(np.abs(nz))).astype(np.int64)  # mid-ranks doubled: integers
    n = len(r2)
    t = ((np.arange(2 ** n, dtype=np.int64)[:, None] >> np.arange(n)) & 1) @ r2
    total = int(r2.sum())
    obs = abs(2 * int(r2[nz > 0].sum()) - total)
    return float(np.count_nonzero(np.abs(2 * t - total) >= obs)) / 2 ** n


def _wilcoxon(d: np.ndarray) -> tuple[float | None, str, float | None]:
    """(p, test name, the smallest p the exact test can give with these pairs). Exact where
    it can be: scipy's exact distribution without ties (up to ``EXACT_UP_TO`` pairs); with ties, over
    all 2^n sign flips (up to ``TIES_EXACT_UP_TO`` pairs), as the normal approximation is no
    guide with few pairs (5 tied pairs, all positive: 0.041 against the exact 0.0625); the
    normal approximation beyond."""
    from scipy import stats

    nz = d[d != 0]
    n = len(nz)
    if n == 0:
        return 1.0, "Wilcoxon signed-rank, two-sided (every difference zero)", None
    ties = len(np.unique(np.abs(nz))) < n
    if ties and n <= TIES_EXACT_UP_TO:
        return _signflip_p(nz), "Wilcoxon signed-rank, two-sided, exact over all 2^n sign flips (ties)", 2.0 / 2 ** n
    exact = not ties and n <= EXACT_UP_TO
    r = stats.wilcoxon(nz, alternative="two-sided", method="exact" if exact else "approx")
    name = "Wilcoxon signed-rank, two-sided, " + ("exact" if exact else "normal approximation") + " (scipy.stats.wilcoxon)"
    return float(r.pvalue), name, (2.0 / 2 ** n if exact else None)


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
            "shown": {1: "method", -1: "control", 0: None}[decision(ci, p, min_p, confidence)[0]],
            "verdict": verdict(ci, p, min_p, names, confidence, n)}


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
    """How many pairs it takes to show a true mean difference ``effect`` with probability
    ``power`` when the differences spread ``sd`` (None: more than ``most``, or no effect):
    the pairs a two-sided paired t-test at ``alpha`` needs, and never fewer than
    ``fewest_pairs`` at that level, below which the signed-rank test that the verdict also
    needs cannot reject, however large the difference (a t-test alone may need only 2)."""
    if not effect or sd is None:
        return None
    floor = fewest_pairs(1.0 - alpha)
    if floor > most:
        return None
    ok = lambda n: n >= floor and detectable(sd, n, alpha, power) <= abs(effect)  # noqa: E731 (falls as n grows)
    lo, hi = 1, 2
    while not ok(hi):
        if hi >= most:
            return None
        lo, hi = hi, min(2 * hi, most)
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


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a success share k/n (95 % by default); (nan, nan) for n = 0."""
    if n == 0:
        return float("nan"), float("nan")
    ph = k / n
    d = 1 + z * z / n
    c = (ph + z * z / (2 * n)) / d
    h = z * math.sqrt(ph * (1 - ph) / n + z * z / (4 * n * n)) / d
    return max(0.0, float(c - h)), min(1.0, float(c + h))


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
               f"{BOOTSTRAP_FROM}, scipy); the test is Wilcoxon's signed-rank (two-sided, zero differences dropped, "
               f"exact up to {TIES_EXACT_UP_TO} pairs with ties and {EXACT_UP_TO} without); d_z is Cohen's effect size of paired "
               "data (mean / sd of the differences). A difference is **shown** only when the interval excludes zero "
               f"and the test rejects at the same level (p < {alpha_of():g}); otherwise it is **not shown**, never a "
               "finding either way, and the verdict says in brackets when the two disagree. The exact test's smallest "
               f"p with n non-zero differences is 2/2^n, so with fewer than {fewest_pairs()} no difference is shown.")
