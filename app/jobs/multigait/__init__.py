"""Job kind ``multigait``: k gaits of a modular robot evolved together (paper 001, Alg. 2),
each gait set scored by what RRT-MP plans with it (coverage of the map or distance to a goal)."""

from __future__ import annotations

from app.jobs.base import Deferred, PackageKind
from app.jobs.multigait import present
from app.jobs.multigait import views as kind_views
from app.jobs.multigait.spec import MultigaitSpec
from app.robots.modular import SHAPES


class MultigaitKind(PackageKind):
    name = "multigait"
    title = "Multiple gaits of a modular robot, evolved together for motion planning"
    paper = "Vonásek & Faigl, evolution of multiple gaits for modular robots, scored by RRT-MP motion planning (paper 001)"
    Spec = MultigaitSpec
    robots = {name: shape.description for name, shape in SHAPES.items()}
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = kind_views.FORM_OPEN  # form groups the dashboard opens first

    # -- members supplied by the package's modules ------------------------------------
    damage_text = staticmethod(present.damage_text)
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    page_tables = staticmethod(present.page_tables)
    figures = staticmethod(present.figures)
    replay_style = staticmethod(present.replay_style)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(kind_views.views)
    history_axis = staticmethod(present.history_axis)  # the page's and the bundle figure's
    verdict = staticmethod(present.verdict)
    verdict_scores = staticmethod(present.verdict_scores)
    metric_names = staticmethod(present.metric_names)

    def robot_info(self, robot):
        return SHAPES[robot].describe()

    def smoke_spec(self):
        return {"kind": "multigait", "robot": "lizard", "search": {"particles": 4, "generations": 2, "seed": 1},
                "planner": {"iterations": 10}, "gait_duration_s": 3.0, "reuse": {"plans": 2, "iterations": 10},
                "verify": {"nodes": 3}}

    # -- members whose modules are slow to import: imported when first called ---------
    run = Deferred(".run", "run")
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.experiments", "BENCH", value=True)


KIND = MultigaitKind()
