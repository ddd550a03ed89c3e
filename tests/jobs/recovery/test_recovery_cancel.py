"""Cancel reaches every post-search phase of recovery: the random-search control stops at its
next generation; the final re-scoring, the control's re-scoring and the robustness re-runs
(one unit of work each) are followed by no later phase once the flag is up."""

import pytest
from cancel_support import PhaseCtx, assert_cancel_stops_in

from app.jobs import registry
from app.jobs.recovery import run as recovery_run

POST = ["random_search", "final_scoring", "random_search_scoring", "robustness", "held_out", "traces"]


class Ctx(PhaseCtx):
    """Raises the cancel flag once progress has entered `cancel_in`; records every phase."""


@pytest.fixture(scope="module")
def full():
    spec = registry.parse_spec(registry.get_kind("recovery").smoke_spec())
    ctx = Ctx()
    res = recovery_run.run(spec, ctx)
    return spec, ctx, res


def test_every_post_search_phase_reports_progress(full):
    _, ctx, res = full
    seen = [p for i, p in enumerate(ctx.phases) if p not in ctx.phases[:i]]
    assert seen == ["search"] + POST
    assert res.summary["robustness"]["total"] > 0


@pytest.mark.parametrize("phase", POST[:-1])  # the traces are the last unit: nothing after them to stop
def test_cancel_stops_every_post_search_phase(full, phase):
    spec, done_ctx, _ = full
    assert_cancel_stops_in(recovery_run.run, spec, done_ctx, phase, POST[POST.index(phase) + 1:], Ctx)
