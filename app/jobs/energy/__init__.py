"""Job kind ``energy``: energy-optimal quadruped gaits with heavy legs (paper 003): a GA over
gait timing and link lengths around an SRB + dummy-leg force NLP, a residual QP on the full
multibody equations, a forward check, and the answer played in full MuJoCo physics."""

from __future__ import annotations

from app.jobs.base import Deferred, PackageKind
from app.jobs.energy import present
from app.jobs.energy.spec import EnergySpec
from app.robots.quadruped import QUADRUPED25, describe


class EnergyKind(PackageKind):
    name = "energy"
    title = "Energy-optimal quadruped gaits with heavy legs"
    paper = "Quadruped gait optimization with leg dynamics: GA + NLP + QP (paper 003)"
    Spec = EnergySpec
    robots = {"quadruped25": "25 kg quadruped of paper 003 (Table 1): 18 DoF, heavy legs"}
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES

    # -- members supplied by the package's modules ------------------------------------
    damage_text = staticmethod(present.damage_text)
    damage_label = "Task"
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    figures = staticmethod(present.figures)
    replay_style = staticmethod(present.replay_style)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(present.views)
    history_axis = staticmethod(present.history_axis)
    verdict_scores = staticmethod(present.verdict_scores)
    metric_names = staticmethod(present.metric_names)

    def robot_info(self, robot):
        return describe(QUADRUPED25)

    def smoke_spec(self):
        return {"kind": "energy", "search": {"population": 4, "generations": 1, "workers": 1}, "model": {"knots": 48},
                "physics": {"periods": 1}, "evidence": {"controls": False, "robustness": False}}

    # -- members whose modules are slow to import: imported when first called ---------
    run = Deferred(".run", "run")
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.experiments", "BENCH", value=True)


KIND = EnergyKind()
