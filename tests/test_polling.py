"""app/core/polling.py: the wait on a served resource returns its final state, says each
new progress line once, and stops at the first state that is no longer pending."""

import time

from app.core.polling import wait_done


def test_waits_until_not_pending_and_logs_each_new_line_once():
    states = iter([{"status": "queued", "n": 0}, {"status": "running", "n": 1}, {"status": "running", "n": 1},
                   {"status": "running", "n": 2}, {"status": "succeeded", "n": 3}, {"status": "running", "n": 9}])
    said = []
    final, wall = wait_done(lambda: next(states), lambda s: f"{s['n']} done", said.append, 0.0, time.monotonic())
    assert final == {"status": "succeeded", "n": 3} and wall >= 0.0
    assert [s.split(" (")[0] for s in said] == ["0 done", "1 done", "2 done"]
