"""Job kind ``multigait``: k gaits of a modular robot evolved together (paper 001, Alg. 2),
each gait set scored by what RRT-MP plans with it (coverage of the map or distance to a goal)."""

from __future__ import annotations

from app.jobs.base import Kind
from app.jobs.multigait import present
from app.jobs.multigait.views import FORM_OPEN
from app.jobs.multigait.spec import MultigaitSpec
from app.robots.modular import SHAPES


class MultigaitKind(Kind):
    name = "multigait"
    title = "Multiple gaits of a modular robot, evolved together for motion planning"
    paper = "Vonásek & Faigl, evolution of multiple gaits for modular robots, scored by RRT-MP motion planning (paper 001)"
    Spec = MultigaitSpec
    robots = {name: shape.description for name, shape in SHAPES.items()}
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = FORM_OPEN  # form groups the dashboard opens first

    def run(self, spec, ctx):
        from app.jobs.multigait.run import run

        return run(spec, ctx)

    def robot_info(self, robot):
        return SHAPES[robot].describe()

    def smoke_spec(self):
        return {"kind": "multigait", "robot": "lizard", "search": {"particles": 4, "generations": 2, "seed": 1},
                "planner": {"iterations": 10}, "gait_duration_s": 3.0, "reuse": {"plans": 2, "iterations": 10},
                "verify": {"nodes": 3}}

    def damage_text(self, spec):
        return present.damage_text(spec.damage.model_dump())

    def headline(self, summary):
        return present.headline(summary)

    def summary_tables(self, summary):
        return present.summary_tables(summary)

    def figures(self, result, out_dir):
        return present.figures(result, out_dir)

    def views(self, summary, traces):
        from app.jobs.multigait.views import views

        return views(summary, traces)

    def history_axis(self, spec):
        from app.jobs.multigait.views import history_axis

        return history_axis(spec)

    def replay_style(self, trace_names):
        return present.replay_style(trace_names)

    def progress_text(self, info):
        return present.progress_text(info)

    def experiments(self):
        from app.jobs.multigait.experiments import EXPERIMENTS

        return EXPERIMENTS

    def bench(self):
        from app.jobs.multigait.experiments import BENCH

        return BENCH


KIND = MultigaitKind()
