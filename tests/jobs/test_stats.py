"""app/jobs/stats.py: paired differences with their interval, test and effect size, the
"shown" rule (interval and test both), the power statement and the binomial interval, against scipy and
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
    ctl = [2.0, 2.2, 2.1, 1.9, 2.4, 2.3, 1.8]
    r = stats.paired([1.0, 1.1, 0.9, 1.05, 1.2, 1.3, 0.95], ctl, higher_is_better=False)
    assert r["mean_diff"] > 0 and r["p"] == pytest.approx(2 / 2 ** 7) and r["verdict"] == "method better (shown)"
    r = stats.paired([3.0, 3.1, 2.9, 3.05, 3.2, 3.3, 2.95], ctl, higher_is_better=False)
    assert r["mean_diff"] < 0 and r["verdict"] == "control better (shown)" and r["shown"] == "control"


def test_degenerate_cases():
    one = stats.paired([1.0], [0.0])
    assert one["ci"] is None and one["verdict"] == "not shown"
    same = stats.paired([2.0, 3.0, 4.0], [1.0, 2.0, 3.0])  # every difference +1: no spread, but 3 pairs
    assert same["ci"] == [1.0, 1.0] and same["effect_size"] is None and same["p"] == pytest.approx(2 / 2 ** 3)
    assert same["verdict"] == "not shown (interval excludes 0, but 3 pairs cannot give Wilcoxon p < 0.05)"
    many = stats.paired(np.arange(10.0) + 1, np.arange(10.0))  # ten equal differences: the test rejects (ties)
    assert many["ci"] == [1.0, 1.0] and many["p"] < 0.05 and many["verdict"] == "method better (shown)"
    zero = stats.paired([1.0, 2.0], [1.0, 2.0])
    assert zero["p"] == 1.0 and zero["verdict"] == "not shown"
    with pytest.raises(ValueError):
        stats.paired([1.0, float("nan")], [1.0, 2.0])
    with pytest.raises(ValueError):
        stats.paired([1.0, 2.0], [1.0])


def test_verdict_needs_the_interval_and_the_test():
    assert stats.verdict([-0.1, 5.0], 0.3) == "not shown"
    assert stats.verdict([0.0, 5.0], 0.3) == "not shown"  # touching zero is not excluding it
    assert stats.verdict([0.1, 5.0], 0.01) == "method better (shown)"
    assert stats.verdict([-5.0, -0.1], 0.01) == "control better (shown)"
    assert stats.verdict(None, None) == "not shown" and stats.verdict(None, 0.01).startswith("not shown (")
    # the interval excludes 0 but the test does not reject: said, and not shown
    assert stats.verdict([0.1, 5.0], 0.2) == "not shown (interval excludes 0, but Wilcoxon p = 0.2 >= 0.05)"
    assert stats.verdict([0.1, 5.0], 0.05) == "not shown (interval excludes 0, but Wilcoxon p = 0.05 >= 0.05)"
    assert stats.verdict([0.1, 5.0], None) == "not shown (interval excludes 0, but there is no test)"
    # the test rejects but the interval includes 0: said, and not shown either
    assert stats.verdict([-0.1, 5.0], 0.01) == "not shown (Wilcoxon p = 0.01 < 0.05, but the interval includes 0)"
    # the level follows the confidence: a 90 % interval goes with p < 0.10
    assert stats.verdict([0.1, 5.0], 0.07, confidence=0.9) == "method better (shown)"
    assert stats.alpha_of(0.95) == 0.05 and stats.fewest_pairs() == 6 and stats.fewest_pairs(0.9) == 5


def test_four_tight_positive_pairs_are_not_shown_though_the_t_interval_excludes_zero():
    """Table II's per-damage rows (issue 28): 4 seeds, every one positive and close; the t
    interval excludes 0, but the exact two-sided signed-rank test cannot go below 2/2^4.
    The old rule said "better (shown)" beside p = 0.125."""
    r = stats.paired([16.0, 17.5, 15.2, 18.1], [10.1, 10.6, 9.8, 10.2], names=("our DE", "random search"))
    assert r["ci"][0] > 0 and r["p"] == pytest.approx(0.125) and r["min_p"] == pytest.approx(0.125)
    assert r["shown"] is None
    assert r["verdict"] == "not shown (interval excludes 0, but 4 pairs cannot give Wilcoxon p < 0.05)"
    text = stats.paired_text(r)
    assert "Wilcoxon p = 0.125, n = 4" in text and "better (shown)" not in text
    # a zero difference is dropped by the test, and the words count the pairs it kept
    z = stats.paired([16.0, 17.5, 15.2, 18.1, 9.0], [10.1, 10.6, 9.8, 10.2, 9.0])
    assert z["verdict"] == "not shown (interval excludes 0, but 4 non-zero pairs cannot give Wilcoxon p < 0.05)"


def test_enough_positive_pairs_are_shown_and_a_mixed_sign_set_is_not():
    rng = np.random.default_rng(3)
    ctl = rng.normal(10, 1, 10)
    r = stats.paired(ctl + rng.uniform(0.5, 1.5, 10), ctl)  # 10 pairs, all positive
    assert r["ci"][0] > 0 and r["p"] == pytest.approx(2 / 2 ** 10) and r["verdict"] == "method better (shown)"
    six = stats.paired([1.1, 1.3, 1.2, 1.25, 1.15, 1.05], [0.0] * 6)  # the fewest that can: p = 1/32
    assert six["p"] == pytest.approx(2 / 2 ** 6) and six["verdict"] == "method better (shown)"
    # mixed signs, 9 pairs: six large positives put the t interval above 0; three small
    # negatives (ranks 1-3) keep the signed-rank p at 2 * 14 / 2^9 = 0.0547, though 9 pairs could go lower
    mixed = stats.paired([5.0, 5.1, 4.9, 5.2, 5.3, 4.8, -0.5, -0.7, -0.8], [0.0] * 9)
    assert mixed["ci"][0] > 0 and mixed["p"] == pytest.approx(28 / 512) and mixed["min_p"] < 0.05 and mixed["shown"] is None
    assert mixed["verdict"] == f"not shown (interval excludes 0, but Wilcoxon p = {mixed['p']:.3g} >= 0.05)"


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


def test_pairs_needed_is_never_fewer_than_the_signed_rank_test_can_reject_with():
    # a large effect: the t-test alone finds it with 2-3 pairs, but below fewest_pairs the
    # signed-rank test (which the "shown" rule also needs) cannot give p < alpha at all
    assert stats.detectable(1.0, 3) <= 10.0
    assert stats.pairs_needed(10.0, 1.0) == stats.fewest_pairs() == 6
    assert stats.pairs_needed(-10.0, 1.0) == 6 and stats.pairs_needed(1.0, 0.0) == 6  # no spread at all
    assert stats.pairs_needed(10.0, 1.0, alpha=0.1) == stats.fewest_pairs(0.9) == 5
    assert stats.pairs_needed(10.0, 1.0, alpha=0.01) == stats.fewest_pairs(0.99) == 8
    # with the floor met, six pairs of that effect are shown by the rule itself
    assert stats.paired([10.0, 10.5, 9.5, 10.2, 9.8, 10.1], [0.0] * 6)["shown"] == "method"
    assert stats.pairs_needed(10.0, 1.0, most=5) is None  # the floor is over the most asked for
    # above the floor the t-test's count stands, as before
    n = stats.pairs_needed(1.0, 2.0)
    assert n > 6 and stats.detectable(2.0, n - 1) > 1.0


def test_pairs_needed_between_a_power_of_two_and_most_is_counted():
    # 787 pairs: the search must not jump from 512 to 1024 and call it "more than 1000"
    n = stats.pairs_needed(0.1, 1.0, most=1000)
    assert 512 < n <= 1000
    assert stats.detectable(1.0, n) <= 0.1 < stats.detectable(1.0, n - 1)
    assert n == stats.pairs_needed(0.1, 1.0)
    assert stats.pairs_needed(0.1, 1.0, most=n - 1) is None and stats.pairs_needed(0.1, 1.0, most=n) == n


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
    t = stats.paired_text(stats.paired([2.0, 3.0, 2.5, 2.2, 2.9, 3.3], [1.0, 1.5, 1.2, 1.1, 1.6, 1.9]), "pts")
    for part in ("pts [", "(95 %)", "d_z =", "Wilcoxon p = 0.0312", "n = 6", "**method better (shown)**"):
        assert part in t
    assert "interval excludes zero and the test rejects" in stats.PAIRED_NOTE and "fewer than 6" in stats.PAIRED_NOTE


def test_tied_differences_take_the_exact_sign_flip_test_not_the_normal_approximation():
    """Five tied pairs, all positive: the normal approximation said p = 0.041 (so "shown"
    with 5 pairs); over all 2^5 sign flips it is 2/32, as without ties."""
    d = np.array([9.0, 10.0, 9.0, 10.0, 11.0])
    r = stats.paired(d, np.zeros(5))
    assert sps.wilcoxon(d, method="approx").pvalue < 0.05  # what the old test said
    assert r["p"] == pytest.approx(2 / 2 ** 5) and r["min_p"] == r["p"] and "sign flips" in r["test"]
    assert r["verdict"] == "not shown (interval excludes 0, but 5 pairs cannot give Wilcoxon p < 0.05)"
    rng = np.random.default_rng(5)
    for n in (4, 7, 12):  # against scipy's own permutation version, ties and zeros included
        x = rng.integers(-2, 5, n).astype(float)
        nz = x[x != 0]
        want = sps.wilcoxon(nz, method=sps.PermutationMethod(n_resamples=2 ** len(nz))).pvalue
        assert stats.paired(x, np.zeros(n))["p"] == pytest.approx(want, abs=1e-12)
    big = stats.paired(np.ones(stats.TIES_EXACT_UP_TO + 1), np.zeros(stats.TIES_EXACT_UP_TO + 1))
    assert "normal approximation" in big["test"] and big["min_p"] is None and big["verdict"] == "method better (shown)"


def test_a_study_pools_through_the_same_rule():
    """app/jobs/verdict.py's ``pooled`` (the study page's verdict over seeds) decides as
    ``paired`` does: 4 tight positive seeds are not "beat"."""
    from app.jobs.verdict import pooled

    four = pooled([5.9, 6.9, 5.4, 7.9])
    assert four["interval"][0] > 0 and four["p"] == pytest.approx(0.125) and four["outcome"] == "not shown"
    assert four["why"] == "the 95 % interval excludes 0, but 4 pairs cannot give Wilcoxon p < 0.05"
    assert four["interval"] == pytest.approx(stats.paired([5.9, 6.9, 5.4, 7.9], [0.0] * 4)["ci"])
    ten = pooled([1.0 + 0.1 * i for i in range(10)])
    assert ten["outcome"] == "beat" and ten["p"] == pytest.approx(2 / 2 ** 10) and "BCa" in ten["interval_method"]
    assert pooled([-1.0 - 0.1 * i for i in range(7)])["outcome"] == "lost"
    assert pooled([3.0, -2.0, 1.0, -5.0, 0.5, 2.0])["why"] == "the 95 % interval includes 0"
    one = pooled([2.0])
    assert one["outcome"] == "not shown" and one["interval"] is None and one["why"] == "one seed: no interval"


def test_wilson_interval_of_a_share():
    lo, hi = stats.wilson(5, 20)
    assert 0.11 < lo < 0.112 and 0.468 < hi < 0.47  # the textbook 95 % Wilson interval of 5/20
    assert stats.wilson(0, 20)[0] == 0.0 and stats.wilson(20, 20)[1] == 1.0  # clamped to [0, 1]
    assert all(x != x for x in stats.wilson(0, 0))  # no models: no interval (nan)
