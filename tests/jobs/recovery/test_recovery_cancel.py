"""Cancel reaches every post-search phase of recovery: the random-search control stops at its
next generation; the final re-scoring, the control's re-scoring and the robustness re-runs
(one unit of work each) are followed by no later phase once the flag is up."""
import copy

import pytest
from cancel_support import PhaseCtx

from app.jobs import registry
from app.jobs.base import Cancelled
from app.jobs.recovery import run as recovery_run

POST = ["random_search", "final_scoring", "random_search_scoring", "robustness", "traces"]


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
    ckpt = copy.deepcopy(done_ctx._ckpt)  # the finished searches: only the later phases run again
    if phase == "random_search":
        ckpt.pop("random_search")
    ctx = Ctx(ckpt=ckpt, cancel_in=phase)
    with pytest.raises(Cancelled):
        recovery_run.run(spec, ctx)
    assert ctx.phases[-1] == phase  # stopped inside the phase, nothing after it ran
    assert ctx.phases.count(phase) == 1  # at its first unit of work
    assert not set(ctx.phases) & set(POST[POST.index(phase) + 1:])
