"""Cancel reaches every post-search phase of energy: the random-search control, the analysis
(the answer in detail, the physics check, each control) and the robustness re-runs stop at
their next unit of work, and no later phase runs."""

import pytest
from cancel_support import PhaseCtx, assert_cancel_stops_in

from app.jobs import registry
from app.jobs.energy import run as energy_run

CONTROLS = ["paper_table1", "srb_only", "high_step", "rod_inertia", "no_residual_iteration"]
POST = (["random_search", "best in detail", "physics check"] + [f"control {c}" for c in CONTROLS]
        + ["controls", "robustness"])


def _key(info):
    if info.get("phase") == "analysis":
        return info["step"] + (f" {info['control']}" if "control" in info else "")
    return info.get("phase")


class Ctx(PhaseCtx):
    """Raises the cancel flag once progress has entered `cancel_in`; records every phase."""

    def phase_of(self, info):
        return _key(info)


def _spec():
    data = registry.get_kind("energy").smoke_spec()
    data["evidence"] = {"controls": True, "robustness": True}  # the smoke spec leaves them out
    return registry.parse_spec(data)


@pytest.fixture(scope="module")
def full():
    spec = _spec()
    ctx = Ctx()
    res = energy_run.run(spec, ctx)
    return spec, ctx, res


def test_every_post_search_phase_reports_progress(full):
    spec, ctx, res = full
    seen = [p for i, p in enumerate(ctx.phases) if p not in ctx.phases[:i]]
    assert seen == ["ga"] + POST
    assert ctx.done == sorted(ctx.done) and res.evaluations == spec.evaluations_budget
    assert res.summary["robustness"] is not None


@pytest.mark.parametrize("phase", POST)
def test_cancel_stops_every_post_search_phase(full, phase):
    spec, done_ctx, _ = full
    assert_cancel_stops_in(energy_run.run, spec, done_ctx, phase, POST[POST.index(phase) + 1:], Ctx)
