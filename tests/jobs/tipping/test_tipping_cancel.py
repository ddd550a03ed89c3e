"""Cancel reaches every post-search phase of tipping: once the robustness re-runs or the band
probes have begun (the controls: tests/jobs/tipping/test_tipping.py), the next simulation does not run
and no later phase starts. The convergence check reuses the dt_half robustness run."""

import pytest
from cancel_support import PhaseCtx

from app.jobs import registry
from app.jobs.base import Cancelled
from app.jobs.tipping import run as tipping_run


@pytest.mark.parametrize("phase", ["robustness", "band"])
def test_cancel_stops_every_post_search_phase(phase):
    data = registry.get_kind("tipping").smoke_spec()
    # the smoke spec leaves out the band and robustness; run the one under test (and, for the
    # robustness, the band after it, which must not start)
    data["evidence"] = {"robustness": True, "band": True} if phase == "robustness" else {"robustness": False, "band": True}
    spec = registry.parse_spec(data)
    ctx = PhaseCtx(cancel_in=phase)  # cancels once progress has entered the phase
    with pytest.raises(Cancelled):
        tipping_run.run(spec, ctx)
    seen = [p for i, p in enumerate(ctx.phases) if p not in ctx.phases[:i]]
    assert seen == ["runs", "controls", phase]  # it got there, and nothing after it started
    assert ctx.phases.count(phase) == 1  # stopped before the phase's second simulation
    assert len(ctx._ckpt[phase]["units"]) == 1  # the simulation it finished is kept
    assert "band" not in ctx._ckpt or phase == "band"
