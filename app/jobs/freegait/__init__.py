"""Job kind ``freegait``: continuous free-crab, circling and spinning gaits of a SILO-6-like
demining hexapod over uneven ground with forbidden zones (paper 004, Estremera, Cobano and
Gonzalez de Santos): the foot-lifting, body-motion and foothold planners of Sec. 2-4 run
every 0.1 s on simulated sensors and walk the robot in MuJoCo; each walk comes with its
controls on the same field (zones ignored, periodic tripod, random valid tripod) and its
robustness re-simulations."""

from __future__ import annotations

from app.jobs.base import Deferred, PackageKind
from app.jobs.freegait import present
from app.jobs.freegait import views as kind_views
from app.jobs.freegait.spec import FreegaitSpec


class FreegaitKind(PackageKind):
    name = "freegait"
    title = "Free-crab gaits over forbidden zones (demining hexapod)"
    paper = ("Estremera, Cobano, Gonzalez de Santos 2010, continuous free-crab gaits for hexapod robots on a natural "
             "terrain with forbidden zones (paper 004)")
    Spec = FreegaitSpec
    robots = {"silo6": "SILO-6-like demining hexapod (paper 004): 54 kg, insect-type 3-DoF legs"}
    history_x = "transfer"
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES

    # -- members supplied by the package's modules ------------------------------------
    damage_text = staticmethod(present.damage_text)
    damage_label = "Route and field"
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    figures = staticmethod(present.figures)
    replay_style = staticmethod(present.replay_style)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(kind_views.views)
    verdict_scores = staticmethod(present.verdict_scores)
    metric_names = staticmethod(present.metric_names)

    def robot_info(self, robot):
        from app.robots.silo6 import describe

        return describe()

    def smoke_spec(self):
        return {"kind": "freegait", "route": {"distance_m": 0.3}, "terrain": {"length_m": 3.0, "width_m": 3.0},
                "forbidden": {"density_per_m2": 6.0}}

    # -- members whose modules are slow to import: imported when first called ---------
    run = Deferred(".run", "run")
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.experiments", "BENCH", value=True)


KIND = FreegaitKind()
