"""Job kind ``recovery``: a damaged hexapod walks again (paper 000): a gait sequence
planned for the remaining legs, then DE over the leg-tip trajectories in MuJoCo."""

from __future__ import annotations

import itertools

from app.jobs.base import Deferred, PackageKind
from app.jobs.recovery import present
from app.jobs.recovery import views as kind_views
from app.jobs.recovery.spec import RecoverySpec
from app.robots.catalog import ROBOTS


class RecoveryKind(PackageKind):
    name = "recovery"
    title = "Gait recovery after leg loss"
    paper = ("Farghdani & Chhabra, evolutionary gait reconfiguration in damaged legged robots: gait-sequence "
             "planning and differential evolution of leg-tip trajectories (paper 000)")
    Spec = RecoverySpec
    robots = {name: r.description for name, r in ROBOTS.items()}
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = kind_views.FORM_OPEN  # form groups the dashboard opens first
    study_order = ("recovery_table2", "recovery_atlas")  # the paper's Table II first

    # -- members supplied by the package's modules ------------------------------------
    damage_text = staticmethod(present.damage_text)
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    figures = staticmethod(present.figures)
    replay_style = staticmethod(present.replay_style)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(kind_views.views)
    history_axis = staticmethod(present.history_axis)  # the page's and the bundle figure's
    study_views = staticmethod(kind_views.study_views)
    metric_names = staticmethod(kind_views.metric_names)  # controls and robustness in cm and deg
    page_tables = staticmethod(kind_views.page_tables)

    user_robots = True  # an uploaded robot by its id (app/jobs/recovery/userrobot.py)

    def bundle_files(self, spec, result):
        from app.jobs.recovery.bundle import bundle_files

        return bundle_files(spec, result)

    def describe_file(self, path):
        from app.jobs.recovery.export import FILES

        return FILES.get(path) or super().describe_file(path)

    def robot_info(self, robot):
        from app.jobs.recovery.trajectory import search_box

        info = ROBOTS[robot].describe()  # the robot's own; the search box is this kind's
        info["parameters"] = search_box(ROBOTS[robot]).describe() | info["parameters"]
        return info

    def user_robot_error(self, spec, legs):
        from app.jobs.recovery.userrobot import spec_error

        return spec_error(spec, legs)

    def smoke_spec(self):
        return {"kind": "recovery", "damage": {"lost_legs": [3, 4]},
                "search": {"population": 6, "generations": 2, "seed": 3}, "sim": {"duration_s": 1.0}}

    def named_values(self):
        # Every 1- and 2-leg loss of the hexapod: the damage atlas's grid (issue 17).
        losses = [[l] for l in range(1, 7)] + [list(c) for c in itertools.combinations(range(1, 7), 2)]
        return {"damage.lost_legs": {"all_feasible_1_and_2": losses}}

    def infeasible_reason(self, data):
        from app.jobs.recovery.sequences import InfeasibleMorphology, check_feasible

        lost = (data.get("damage") or {}).get("lost_legs") if isinstance(data.get("damage"), dict) else None
        if not isinstance(lost, list) or not all(isinstance(l, int) and not isinstance(l, bool) for l in lost):
            return None
        try:
            check_feasible([l for l in range(1, 7) if l not in lost])
        except InfeasibleMorphology as e:
            return str(e) or "no statically stable gait on the remaining legs"
        return None

    # -- members whose modules are slow to import: imported when first called ---------
    run = Deferred(".run", "run")
    play = Deferred(".play", "play")  # an answer on another damage and world (app/adapt's DE arm)
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.bench", "BENCH", value=True)


KIND = RecoveryKind()
