"""`gaitmend verify`'s three outcomes (issue 45): identical, equal within the stated
tolerance (a floating-point-order difference that did not grow), different; with the
figures it prints (numbers compared, how many differ, the largest difference and where)."""

from __future__ import annotations

import math

from app.results.verify import ABS_TOL, REL_TOL, compare

RESULT = {"best": {"fitness": 12.38, "x": [0.1, -0.2, 0.0]}, "history": [[0, 1.5], [1, 2.5]],
          "robust": {"ok": True, "k": 7}, "timing": {"wall_s": 3.2, "evaluations": 400}}


def _with(path: list, value):
    import copy

    out = copy.deepcopy(RESULT)
    node = out
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return out


def test_identical_counts_every_number_and_skips_the_clock():
    c = compare(RESULT, _with(["timing", "wall_s"], 99.0))
    assert c.outcome == "identical" and c.first is None
    assert c.numbers == 10 and c.differing == 0  # fitness, x (3), history (4), k, evaluations; not wall_s
    assert c.text().startswith("identical: same numbers, all 10")


def test_a_rounding_level_difference_is_within_tolerance_and_says_where():
    c = compare(RESULT, _with(["history", 1, 1], 2.5 * (1 + REL_TOL / 10)))
    assert c.outcome == "within_tolerance" and c.differing == 1 and c.where == "history.1.1"
    assert math.isclose(c.max_rel, REL_TOL / 10, rel_tol=0.01)
    near_zero = compare(RESULT, _with(["best", "x", 2], ABS_TOL / 2))  # relative 1 at zero, absolute tiny
    assert near_zero.outcome == "within_tolerance"


def test_beyond_the_tolerance_or_any_other_change_is_different():
    far = compare(RESULT, _with(["best", "fitness"], 13.04))
    assert far.outcome == "different" and far.first == "best.fitness: bundle 12.38, new run 13.04"
    assert math.isclose(far.max_rel, 0.66 / 13.04) and far.where == "best.fitness"
    # one number far, one near: different, and the figures are the far one's
    both = compare(RESULT, _with(["best", "x", 0], 0.1 * (1 + REL_TOL / 10)) | {"history": [[0, 1.5], [1, 3.5]]})
    assert both.outcome == "different" and both.differing == 2 and both.beyond == 1
    assert compare(RESULT, _with(["robust", "ok"], False)).outcome == "different"  # a flag: no tolerance
    shorter = compare(RESULT, _with(["history"], [[0, 1.5]]))
    assert shorter.outcome == "different" and "2 items in the bundle, 1 in the new run" in shorter.first
    assert compare(RESULT, _with(["timing", "evaluations"], 401)).outcome == "different"  # counts must agree
