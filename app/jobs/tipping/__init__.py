"""Job kind ``tipping``: sideline tipping judgment and recovery of a heavy-duty hexapod
(paper 002): FASM every control step, judgment at a threshold with a time-to-tip estimate,
one swing leg caught onto the optimal foothold, QP foot forces; each scenario is run with
and without recovery, optionally swept over tilt directions x both tripods."""

from __future__ import annotations

from app.jobs.base import Deferred, PackageKind
from app.jobs.tipping import present
from app.jobs.tipping import views as kind_views
from app.jobs.tipping.spec import TippingSpec
from app.robots.heavy_hexapod import HEAVY, describe


class TippingKind(PackageKind):
    name = "tipping"
    title = "Tipping judgment and recovery of a heavy-duty hexapod"
    paper = "Zhang et al. 2024, sideline tipping judgment and recovery of a heavy-duty hexapod (paper 002)"
    Spec = TippingSpec
    robots = {HEAVY.name: describe(HEAVY)["description"]}
    history_x = "run"
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = kind_views.FORM_OPEN  # form groups the dashboard opens first

    # -- members supplied by the package's modules ------------------------------------
    damage_text = staticmethod(present.damage_text)
    damage_label = "Scenario"
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    figures = staticmethod(present.figures)
    replay_style = staticmethod(present.replay_style)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(kind_views.views)
    history_axis = staticmethod(kind_views.history_axis)
    verdict_scores = staticmethod(present.verdict_scores)
    metric_names = staticmethod(present.metric_names)
    study_views = staticmethod(kind_views.study_views)

    def smoke_spec(self):
        # Five short simulations (the runs with and without recovery, three controls): the
        # evidence path and its checkpoints without the band's and robustness's 23 runs.
        return {"kind": "tipping", "scenario": {"type": "tilt", "hold_s": 0.5},
                "evidence": {"robustness": False, "band": False}}

    def robot_info(self, robot):
        return describe(HEAVY)

    # -- members whose modules are slow to import: imported when first called ---------
    run = Deferred(".run", "run")
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.experiments", "BENCH", value=True)


KIND = TippingKind()
