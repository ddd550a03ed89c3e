"""The staircase (paper 001, Sec. V) at a small budget, recorded (issue 28): ``gaitmend
reproduce multigait-stairs`` runs the ``multigait`` job on the stairs map as `gaitmend run`
does and appends it to docs/multigait_stairs.json. On the staircase every tree expansion is
a full simulation from the parent's state, so the search's cost grows with particles x
planner iterations; the paper-size cost is *estimated* from this run's measured simulation
steps per generation and steps per second, scaled linearly to the paper's budget."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, Field

from app.jobs.base import MemoryContext, dumps
from app.jobs.ledger import Ledger, current_runs
from app.jobs.multigait.reproduce.paper_rows import NAMES, SCIENCE
from app.jobs.reporting import missing, progress_note

STAIRS_JSON = "docs/multigait_stairs.json"
STAIRS_COMMAND = "gaitmend reproduce multigait-stairs --write-docs"


class StairsParams(BaseModel):
    robot: Literal["lizard", "quadropod"] = Field("quadropod", description="the modular robot (the paper's staircase "
                                                                         "robots)")
    particles: int = Field(4, ge=2, le=40, description="PSO particles")
    generations: int = Field(2, ge=1, le=150, description="PSO generations after the initial swarm")
    iterations: int = Field(8, ge=1, le=150, description="planner iterations K of each tree (the paper: 150)")
    seed: int = Field(0, ge=0, le=2**31 - 1)
    paper_particles: int = Field(20, ge=1, le=200, description="the paper's particles (the estimate's target)")
    paper_generations: int = Field(150, ge=1, le=1000, description="the paper's generations (the estimate's target)")
    json_out: Path | None = Field(Path(STAIRS_JSON), description="the ledger: one run per spec")


def stairs_spec(p: StairsParams) -> dict:
    return {"kind": "multigait", "robot": p.robot, "map": "stairs", "cost": "distance",
            "search": {"particles": p.particles, "generations": p.generations, "seed": p.seed},
            "planner": {"iterations": p.iterations}}


def _stairs_job(data: dict) -> dict:
    """The job (app/jobs/multigait/run.py, as `gaitmend run` calls it) and what the page
    states: the best tree's nodes with the ground under each, its distance to the goal, the
    search phase's own simulation steps and wall time (from its checkpoint), the job's timing."""
    from app.jobs.multigait.planner.maps import MAPS
    from app.jobs.multigait.run import run
    from app.jobs.multigait.spec import MultigaitSpec

    spec, ctx = MultigaitSpec.parse(data), MemoryContext()
    s = json.loads(dumps(run(spec, ctx).summary))
    search = (ctx.load_checkpoint() or {})["search"]
    pos = np.asarray(s["tree"]["pos_mu"], dtype=float)
    ground = MAPS["stairs"].height_at(pos[:, 0], pos[:, 1])
    return {"robot": s["robot"], "gaits": s["gaits"], "iterations": s["iterations"], "paper_iterations":
            MultigaitSpec.parse(data | {"planner": {}}).iterations, "result": s["result"],
            "nodes": [{"x": float(x), "y": float(y), "z": float(z), "ground": float(g)}
                      for (x, y, z), g in zip(pos, ground)],
            "steps": [b[1][2] * 2 for b in s["map"]["terrain_boxes"]], "goal": s["map"]["goal"],
            "search": {"generations_run": s["search"]["generations_run"], "evaluations": search["evaluations"],
                       "sim_steps": int(search["totals"]["sim_steps"]), "wall_s": search["wall_s"]},
            "controls": s["controls"], "timing": s["timing"]}


def stairs(p: StairsParams, log: Callable[[str], None]) -> str:
    led = Ledger(p.json_out, "multigait-stairs", STAIRS_COMMAND, p.model_dump(mode="json"), SCIENCE, planned=1)
    data = stairs_spec(p)
    log(f"multigait staircase: {p.robot}, PSO {p.particles} x ({p.generations} + 1), K = {p.iterations} ...")
    led.run(f"{p.robot} stairs {p.particles}x{p.generations} K{p.iterations} seed {p.seed}", data, p.seed,
            lambda: _stairs_job(data), log)
    return render_stairs([led.data])


def paper_estimate(r: dict, particles: int, generations: int) -> dict:
    """The paper-size staircase search, estimated from one run: its search steps per
    generation scaled by particles and planner iterations, timed at its measured search
    rate (steps per second). Hours for the search, and for the job's two searches (the
    random-search control runs the same budget)."""
    se = r["search"]
    per_gen = se["sim_steps"] / se["generations_run"]
    spec_particles = se["evaluations"] / se["generations_run"]
    paper_per_gen = per_gen * particles / spec_particles * r["paper_iterations"] / r["iterations"]
    rate = se["sim_steps"] / se["wall_s"]
    hours = paper_per_gen * (generations + 1) / rate / 3600
    return {"steps_per_generation": per_gen, "paper_steps_per_generation": paper_per_gen, "steps_per_s": rate,
            "search_h": hours, "job_h": 2 * hours}


def estimate_text(r: dict, particles: int, generations: int) -> str:
    e = paper_estimate(r, particles, generations)
    return (f"an estimate, not a measurement: {e['paper_steps_per_generation'] / 1e6:.1f} M steps per generation at "
            f"{particles} particles and K = {r['paper_iterations']} (this run's {e['steps_per_generation'] / 1e6:.2f} M "
            f"scaled linearly by particles and K), {generations} + 1 generations at this run's "
            f"{e['steps_per_s'] / 1e3:.1f}k steps/s: about {e['search_h']:.0f} h for the search, "
            f"{e['job_h']:.0f} h with its equal-budget random search")


# issue 12's hand-typed record of the same spec (no data kept), quoted so the page can set it against the data
EARLIER = {"top_z_mu": 1.1, "goal_distance_mu": 19.8, "job_wall_s": 78.0, "paper_steps_per_generation": 18.6e6,
           "paper_h": 30.0}


def _against_earlier(r: dict, row: dict, e: dict) -> str:
    top = max(n["z"] for n in r["nodes"])
    same = lambda a, b, tol: "the same" if abs(a - b) <= tol else "**different**"  # noqa: E731
    return (f"Against issue 12's hand-typed record of this spec (highest node z = {EARLIER['top_z_mu']:g} mu, "
            f"{EARLIER['goal_distance_mu']:g} mu from the goal, {EARLIER['job_wall_s']:.0f} s under load, "
            f"{EARLIER['paper_steps_per_generation'] / 1e6:.1f} M steps per paper-size generation, ~{EARLIER['paper_h']:.0f} h "
            f"a paper-size run on two cores): highest node {same(top, EARLIER['top_z_mu'], 0.05)}, distance to the goal "
            f"{same(r['result']['goal_distance_mu'], EARLIER['goal_distance_mu'], 0.05)}, steps per paper-size generation "
            f"{same(e['paper_steps_per_generation'] / 1e6, EARLIER['paper_steps_per_generation'] / 1e6, 0.05)}; the job took "
            f"{row['wall_s'] / EARLIER['job_wall_s']:.1f}x the recorded wall time (its analysis after the two searches, "
            f"held-out plans and robustness re-simulations simulated on this map, took {r['timing']['analysis_s']:.0f} s "
            f"of it), and the paper-size estimate is {e['search_h'] / EARLIER['paper_h']:.1f}x the recorded "
            f"~{EARLIER['paper_h']:.0f} h, at the rate this shared machine gave.\n")


def render_stairs(datas: list) -> str:
    data = datas[0]
    runs = current_runs(data) if data else []
    if not runs:
        return missing(STAIRS_JSON, STAIRS_COMMAND)
    row, r, p = runs[-1], runs[-1]["result"], data["params"]
    nodes, se = r["nodes"], r["search"]
    top = max(nodes, key=lambda n: n["z"])
    climbed = sum(n["ground"] > 0 for n in nodes)
    steps = r["steps"]
    tm = r["timing"]
    e = paper_estimate(r, p["paper_particles"], p["paper_generations"])
    return (f"```\n{json.dumps(row['spec'])}\n```\n\n"
            f"{NAMES.get(r['robot'], r['robot'])}, k = {r['gaits']} gaits, K = {r['iterations']}; {len(steps)} steps of "
            f"{steps[0]:g} mu up to a plateau at {steps[-1]:g} mu, the goal at z = {r['goal'][2]:g} mu. The best tree has "
            f"{len(nodes)} nodes, {climbed} of them over a step; its highest node is at z = {top['z']:.2f} mu over ground "
            f"at {top['ground']:g} mu (start z = {nodes[0]['z']:.2f} mu), and it ends "
            f"{r['result']['goal_distance_mu']:.1f} mu from the goal. The search simulated "
            f"{e['steps_per_generation'] / 1e6:.2f} M steps per generation ({se['generations_run']} generations, "
            f"{se['wall_s']:.0f} s, {e['steps_per_s'] / 1e3:.1f}k steps/s); the whole job (with its random-search "
            f"control, held-out plans and robustness re-simulations) took {row['wall_s']:.0f} s wall, "
            f"{row['cpu_s']:.0f} s CPU, {tm['sim_steps'] / 1e6:.1f} M steps, niced beside other work.\n\n"
            f"A paper-size staircase run ({p['paper_particles']} x {p['paper_generations']}) is "
            f"{estimate_text(r, p['paper_particles'], p['paper_generations'])}. The rate was measured niced on a shared "
            f"machine (the job averaged {row['cpu_s'] / max(row['wall_s'], 1e-9):.2f} cores of CPU over its wall time), so the "
            "hours are this machine's under that load, not an idle machine's.\n\n"
            + _against_earlier(r, row, e) + progress_note(data, len(runs)))
