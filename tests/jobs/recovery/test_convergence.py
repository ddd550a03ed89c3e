"""The convergence rule's arithmetic (the rule on real answers: tests/jobs/test_recovery.py)."""

import numpy as np

from app.jobs.recovery.reproduce.convergence import RULE, check, halving_deltas


def metrics(x_cm, y_cm, yaw):
    return {"x_f_m": np.array(x_cm) / 100, "y_f_m": np.array(y_cm) / 100, "yaw_f_deg": np.array(yaw, dtype=float)}


def test_rule_accepts_small_moves_and_rejects_a_forward_jump():
    a = metrics([0, 1, 2, 3, 4], [100] * 5, [0, 0, 0, 0, 0])
    b = metrics([1, 2, 3, 4, 12], [102] * 5, [1, 1, 1, 1, 1])  # one answer's drift moves 8 cm: 4/5 within
    r = check(halving_deltas(a, b))
    assert r["passes"] and r["share_within"] == 0.8 and abs(r["max_lateral_m"] - 0.08) < 1e-12
    b2 = metrics([1, 2, 3, 4, 5], [102, 102, 102, 102, 94], [1] * 5)  # a 6 % forward change fails every time
    assert not check(halving_deltas(a, b2))["passes"]


def test_rule_rejects_when_too_many_answers_drift():
    a = metrics([0] * 5, [100] * 5, [0] * 5)
    b = metrics([0, 0, 0, 6, 6], [100] * 5, [0, 0, 0, 0, 0])
    r = check(halving_deltas(a, b))
    assert r["share_within"] == 0.6 < RULE["share"] and not r["passes"]
    b = metrics([0] * 5, [100] * 5, [0, 0, 0, 11, 11])  # yaw counts too
    assert not check(halving_deltas(a, b))["passes"]
