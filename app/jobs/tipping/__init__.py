"""Job kind ``tipping``: sideline tipping judgment and recovery of a heavy-duty hexapod
(paper 002): FASM every control step, judgment at a threshold with a time-to-tip estimate,
one swing leg caught onto the optimal foothold, QP foot forces; each scenario is run with
and without recovery, optionally swept over tilt directions x both tripods."""

from __future__ import annotations

from app.jobs.base import Kind
from app.jobs.tipping import present
from app.jobs.tipping.views import FORM_OPEN
from app.jobs.tipping.spec import TippingSpec
from app.robots.heavy_hexapod import HEAVY, describe


class TippingKind(Kind):
    name = "tipping"
    title = "Tipping judgment and recovery of a heavy-duty hexapod"
    paper = "Zhang et al. 2024, sideline tipping judgment and recovery of a heavy-duty hexapod (paper 002)"
    Spec = TippingSpec
    robots = {HEAVY.name: describe(HEAVY)["description"]}
    history_x = "run"
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = FORM_OPEN  # form groups the dashboard opens first

    def run(self, spec, ctx):
        from app.jobs.tipping.run import run

        return run(spec, ctx)

    def smoke_spec(self):
        # Five short simulations (the runs with and without recovery, three controls): the
        # evidence path and its checkpoints without the band's and robustness's 23 runs.
        return {"kind": "tipping", "scenario": {"type": "tilt", "hold_s": 0.5},
                "evidence": {"robustness": False, "band": False}}

    def robot_info(self, robot):
        return describe(HEAVY)

    def damage_text(self, spec):
        return present.damage_text(spec.scenario.model_dump())

    def headline(self, summary):
        return present.headline(summary)

    def summary_tables(self, summary):
        return present.summary_tables(summary)

    def figures(self, result, out_dir):
        return present.figures(result, out_dir)

    def views(self, summary, traces):
        from app.jobs.tipping.views import views

        return views(summary, traces)

    def study_views(self, study, points):
        from app.jobs.tipping.views import study_views

        return study_views(study, points)

    def history_axis(self, spec):
        from app.jobs.tipping.views import history_axis

        return history_axis(spec)

    def replay_style(self, trace_names):
        return present.replay_style(trace_names)

    def progress_text(self, info):
        return present.progress_text(info)

    def experiments(self):
        from app.jobs.tipping.experiments import EXPERIMENTS

        return EXPERIMENTS

    def bench(self):
        from app.jobs.tipping.experiments import BENCH

        return BENCH


KIND = TippingKind()
