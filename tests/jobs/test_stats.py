"""app/jobs/stats.py: paired differences with their interval, test and effect size, the
"not shown" rule, the power statement and the binomial interval, against scipy and
against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as sps

from app.jobs import stats


def test_paired_t_interval_below_ten_pairs():
    a, b = [18.1, 17.1, 21.5, 16.3, 17.8], [18.3, 15.4, 16.7, 14.7, 17.4]
    r = stats.paired(a, b)
    d = np.subtract(a, b)
    lo, hi = sps.t.interval(0.95, 4, loc=d.mean(), scale=d.std(ddof=1) / math.sqrt(5))
    assert r["n"] == 5 and r["mean_diff"] == pytest.approx(d.mean())
    assert r["ci"] == pytest.approx([lo, hi]) and "Student t" in r["ci_method"]
    assert r["effect_size"] == pytest.approx(d.mean() / d.std(ddof=1))
    assert r["p"] == pytest.approx(sps.wilcoxon(d, method="exact").pvalue)
    assert r["min_p"] == pytest.approx(2 / 2 ** 5)  # five pairs can never reach p < 0.05
    assert r["verdict"] == "not shown"  # the interval includes zero


def test_paired_bootstrap_from_ten_pairs_and_a_shown_difference():
    rng = np.random.default_rng(1)
    ctl = rng.normal(10, 1, 12)
    r = stats.paired(ctl + 2.0 + rng.normal(0, 0.3, 12), ctl, names=("A", "B"))
    assert "BCa bootstrap" in r["ci_method"] and r["ci"][0] > 0
    assert r["verdict"] == "A better (shown)"
    assert r["ci"][0] < r["mean_diff"] < r["ci"][1]


def test_lower_is_better_orients_the_difference():
    r = stats.paired([1.0, 1.1, 0.9, 1.0], [2.0, 2.2, 2.1, 1.9], higher_is_better=False)
    assert r["mean_diff"] > 0 and r["verdict"] == "method better (shown)"
    r = stats.paired([3.0, 3.1, 2.9, 3.0], [2.0, 2.2, 2.1, 1.9], higher_is_better=False)
    assert r["verdict"] == "control better (shown)"


def test_degenerate_cases():
    one = stats.paired([1.0], [0.0])
    assert one["ci"] is None and one["verdict"] == "not shown"
    same = stats.paired([2.0, 3.0, 4.0], [1.0, 2.0, 3.0])  # every difference +1: no spread
    assert same["ci"] == [1.0, 1.0] and same["effect_size"] is None and same["verdict"] == "method better (shown)"
    zero = stats.paired([1.0, 2.0], [1.0, 2.0])
    assert zero["p"] == 1.0 and zero["verdict"] == "not shown"
    with pytest.raises(ValueError):
        stats.paired([1.0, float("nan")], [1.0, 2.0])
    with pytest.raises(ValueError):
        stats.paired([1.0, 2.0], [1.0])


def test_verdict_rule_is_the_interval_alone():
    assert stats.verdict([-0.1, 5.0]) == "not shown"
    assert stats.verdict([0.0, 5.0]) == "not shown"  # touching zero is not excluding it
    assert stats.verdict([0.1, 5.0]) == "method better (shown)"
    assert stats.verdict([-5.0, -0.1]) == "control better (shown)"
    assert stats.verdict(None) == "not shown"


def test_detectable_difference_matches_the_power_it_states():
    sd, n = 1.0, 30
    d = stats.detectable(sd, n)
    # close to the normal approximation (z_0.975 + z_0.8) sd / sqrt(n) = 0.511, a little above it (t)
    assert 0.51 < d < 0.56
    tc = sps.t.ppf(0.975, n - 1)
    nc = d / (sd / math.sqrt(n))
    assert sps.nct.sf(tc, n - 1, nc) + sps.nct.cdf(-tc, n - 1, nc) == pytest.approx(0.8, abs=1e-6)
    assert stats.detectable(1.0, 2) > stats.detectable(1.0, 5) > d  # fewer pairs, larger effects only
    assert stats.detectable(1.0, 1) is None and stats.detectable(0.0, 5) == 0.0


def test_pairs_needed():
    n = stats.pairs_needed(1.0, 2.0)
    assert stats.detectable(2.0, n) <= 1.0 < stats.detectable(2.0, n - 1)
    assert stats.pairs_needed(0.0, 1.0) is None


def test_success_rate_is_clopper_pearson():
    r = stats.success_rate(0, 20)
    assert r["ci"][0] == 0.0 and r["ci"][1] == pytest.approx(1 - 0.025 ** (1 / 20))  # the exact upper bound for k = 0
    r = stats.success_rate(3, 20)
    assert r["rate"] == 0.15
    assert sps.binom.sf(2, 20, r["ci"][0]) == pytest.approx(0.025, abs=1e-6)  # P(X >= 3 | p_lo) = alpha / 2
    assert sps.binom.cdf(3, 20, r["ci"][1]) == pytest.approx(0.025, abs=1e-6)
    assert stats.rate_text(r) == "3/20 = 0.15 [0.03, 0.38]"
    assert stats.success_rate(0, 0)["rate"] is None


def test_paired_text_names_everything_a_referee_asks_for():
    t = stats.paired_text(stats.paired([2.0, 3.0, 2.5], [1.0, 1.5, 1.2]), "pts")
    for part in ("pts [", "(95 %)", "d_z =", "Wilcoxon p =", "n = 3", "**method better (shown)**"):
        assert part in t
