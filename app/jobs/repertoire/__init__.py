"""Job kind ``repertoire``: a map of thousands of different gaits for a robot with a leg
map, built before (or for) a damage with MAP-Elites (Intelligent Trial and Error, Cully,
Clune, Tarapore & Mouret, Nature 521, 2015) through pyribs, scored in batched native
MuJoCo rollouts, beside a random search at the same budget."""

from __future__ import annotations

from app.jobs.base import Deferred, PackageKind
from app.jobs.repertoire import present
from app.jobs.repertoire import views as kind_views
from app.jobs.repertoire.spec import RepertoireSpec


class RepertoireKind(PackageKind):
    name = "repertoire"
    title = "Gait repertoire (MAP-Elites map of gaits)"
    paper = ("Cully, Clune, Tarapore & Mouret, Robots that can adapt like animals, Nature 521 (2015): Intelligent "
             "Trial and Error's behaviour-performance map, built with MAP-Elites")
    Spec = RepertoireSpec
    robots = {"jethexa": "JetHexa-like 18-DoF hexapod (the recovery hexapod), any of its legs lost or joints locked"}
    history_x = "iteration"
    history_columns = present.HISTORY_COLUMNS
    trace_descriptions = present.TRACES
    figure_descriptions = present.FIGURES
    form_open = ("damage", "search")
    study_order = ("repertoire_priors",)  # the priors an adaptation holds first, then the islands of one map

    damage_text = staticmethod(present.damage_text)
    headline = staticmethod(present.headline)
    summary_tables = staticmethod(present.summary_tables)
    figures = staticmethod(present.figures)
    progress_text = staticmethod(present.progress_text)
    views = staticmethod(kind_views.views)
    study_views = staticmethod(kind_views.study_views)  # a study of islands: the merged map
    page_tables = staticmethod(present.page_tables)  # the page draws the map's table and best elites itself
    replay_style = staticmethod(present.replay_style)  # the best gait, then the elites picked for a replay
    history_axis = staticmethod(present.history_axis)
    verdict_scores = staticmethod(present.verdict_scores)
    metric_names = staticmethod(present.metric_names)

    user_robots = True  # an uploaded robot by its id: its leg map drives the controller

    def bundle_files(self, spec, result):
        from app.jobs.repertoire.export import bundle_files

        return bundle_files(spec, result)

    def describe_file(self, path):
        from app.jobs.repertoire.export import describe

        return describe(path) or super().describe_file(path)

    def user_robot_error(self, spec, legs):
        from app.jobs.repertoire.body import uploaded_error

        return uploaded_error(spec, legs)

    def robot_info(self, robot):
        # /api/robots merges every kind's details of a robot: only keys of this kind's own
        from app.jobs.repertoire.controller import n_params
        from app.robots.catalog import get_robot

        entry = get_robot(robot)
        return {"leg_names": [f"leg{n}" for n in entry.legs],
                "controller_parameters": n_params(len(entry.legs) * len(entry.joints))}

    def smoke_spec(self):
        return {"kind": "repertoire", "seed": 2, "archive": {"cells": 20},
                "search": {"iterations": 2, "batch_size": 6, "checkpoint_every": 1},
                "sim": {"duration_s": 0.3, "settle_s": 0.1, "timestep_s": 0.002}, "evidence": {"rescore_elites": 2}}

    run = Deferred(".run", "run")
    play = Deferred(".play", "play")  # the adaptation's simulated reality (app/adapt/reality.py)
    # evidence (`gaitmend reproduce repertoire`), emitter, timestep, then islands (a map over workers, measured)
    experiments = Deferred(".reproduce.experiments", "EXPERIMENTS", value=True)
    bench = Deferred(".reproduce.bench", "BENCH", value=True)


KIND = RepertoireKind()
