"""Cancel reaches every post-search phase of freegait: once the controls or the robustness
re-runs have begun, the next unit does not run and no later phase starts."""
import copy

import pytest
from cancel_support import PhaseCtx

from app.jobs import registry
from app.jobs.base import Cancelled
from app.jobs.freegait import run as freegait_run

GROUPS = ["walk", "control", "robustness"]


class Ctx(PhaseCtx):
    """Raises the cancel flag once progress has entered the phase `cancel_in`; records every
    unit's phase (its group) in the order their progress came."""

    def __init__(self, groups, ckpt=None, cancel_in=None):
        super().__init__(ckpt=ckpt, cancel_in=cancel_in)
        self.group_of = groups

    def phase_of(self, info):
        assert info["phase"] == self.group_of[info["run"]]  # the phases are the unit groups
        return info["phase"]


@pytest.fixture(scope="module")
def full():
    spec = registry.parse_spec(registry.get_kind("freegait").smoke_spec())
    groups = {name: g for g, name, _ in freegait_run.unit_configs(spec)}
    ctx = Ctx(groups)
    res = freegait_run.run(spec, ctx)
    return spec, groups, ctx, res


def test_every_phase_reports_progress(full):
    _, groups, ctx, res = full
    assert [p for i, p in enumerate(ctx.phases) if p not in ctx.phases[:i]] == GROUPS
    assert len(ctx.phases) == len(groups) and res.summary["robustness"]["total"] > 0


@pytest.mark.parametrize("phase", ["control", "robustness"])
def test_cancel_stops_every_post_search_phase(full, phase):
    spec, groups, done_ctx, _ = full
    later = GROUPS[GROUPS.index(phase):]
    # the phase and the ones after it are still to run; the walk is done (its trace re-run)
    ckpt = {g: entry for g, entry in copy.deepcopy(done_ctx._ckpt).items() if g not in later}
    ctx = Ctx(groups, ckpt=ckpt, cancel_in=phase)
    with pytest.raises(Cancelled):
        freegait_run.run(spec, ctx)
    assert ctx.phases[-1] == phase and ctx.phases.count(phase) == 1  # stopped at the phase's next unit
    assert not set(ctx.phases) & set(later[1:])
    assert len(ctx._ckpt[phase]["units"]) == 1 and not set(ctx._ckpt) & set(later[1:])  # one unit of the phase ran


def test_cancel_inside_a_walk_stops_it(full):
    spec, groups, _, _ = full
    ctx = Ctx(groups)
    calls = [0]
    ctx.is_cancelled = lambda: (calls.__setitem__(0, calls[0] + 1) or calls[0] > 3)  # mid-walk, not between units
    with pytest.raises(Cancelled):
        freegait_run.run(spec, ctx)
    assert ctx.phases == [] and ctx._ckpt is None
