"""A small job kind defined outside app/, registered through GAITMEND_EXTRA_KINDS: a ball
launched on a plane (real MuJoCo, batched rollouts), DE over its launch velocity so that
it comes to rest at a target distance. It proves that a kind is one package and one
registry entry: the CLI, API, worker, bundle and replay drive it with no edit to app/."""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar, Literal

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from mujoco import rollout  # noqa: E402
from pydantic import Field  # noqa: E402

from app.jobs.base import (Experiment, JobResult, Kind, ReplayTrack, SpecBase, StrictModel,  # noqa: E402
                           headline_row, table)
from app.jobs.loop import Generation, StopRules, run_search  # noqa: E402
from app.optim.registry import make_optimizer  # noqa: E402

XML = """<mujoco><option timestep="0.005"/>
<worldbody><geom name="floor" type="plane" size="20 20 0.1" friction="0.8 0.02 0.01"/>
<body name="ball" pos="0 0 0.05"><freejoint/><geom type="sphere" size="0.05" mass="0.2"/></body>
</worldbody></mujoco>"""
STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS


class Search(StrictModel):
    population: int = Field(6, ge=4, le=64)
    generations: int = Field(3, ge=0, le=50)
    seed: int = Field(0, ge=0, le=2**32 - 1)


class BallisticSpec(SpecBase):
    kind: Literal["ballistic"] = "ballistic"
    robot: Literal["ball"] = "ball"
    target_m: float = Field(2.0, gt=0.1, le=10.0)
    duration_s: float = Field(1.5, gt=0.1, le=5.0)
    search: Search = Field(default_factory=Search)
    stop: StopRules = Field(default_factory=StopRules)
    budget_formula: ClassVar[str] = "population x (generations + 1) launches, + 1 replay of the best"
    budget_field: ClassVar[str] = "search.generations"

    @property
    def seed(self) -> int:
        return self.search.seed

    @property
    def evaluations_budget(self) -> int:
        return self.search.population * (self.search.generations + 1) + 1


def _launch(model, v: np.ndarray, nstep: int) -> np.ndarray:
    """Full-physics states (B, nstep, n) of balls launched with velocities v (B, 2)."""
    data = mujoco.MjData(model)
    s0 = np.empty(mujoco.mj_stateSize(model, STATE))
    mujoco.mj_getState(model, data, s0, STATE)
    init = np.repeat(s0[None], len(v), 0)
    nq = model.nq
    qvel = 1 + nq  # state layout: time, qpos, qvel, ...
    init[:, qvel + 0] = v[:, 0]
    init[:, qvel + 2] = v[:, 1]
    state, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(len(v))], init, nstep=nstep)
    return state


def run(spec: BallisticSpec, ctx) -> JobResult:
    model = mujoco.MjModel.from_xml_string(XML)
    nstep = int(round(spec.duration_s / model.opt.timestep))
    opt = make_optimizer("de", np.array([0.0, 0.0]), np.array([6.0, 4.0]), spec.search.population, spec.seed)

    def evaluate(v: np.ndarray) -> Generation:
        x = _launch(model, v, nstep)[:, -1, 1]
        return Generation(-np.abs(x - spec.target_m), {}, {"sim_steps": len(v) * nstep})

    out = run_search(opt, evaluate, spec.search.generations, ctx, spec.stop, sign=-1.0)
    best = _launch(model, out.best_x[None], nstep)[0]
    t = (np.arange(nstep) + 1) * model.opt.timestep
    trace = {"time_s": t, "qpos": best[:, 1:1 + model.nq], "com_m": best[:, 1:4]}
    error = float(abs(best[-1, 1] - spec.target_m))
    summary = {"kind": "ballistic", "robot": spec.robot, "seed": spec.seed, "target_m": spec.target_m,
               "best": {"velocity_m_s": out.best_x.tolist(), "rest_x_m": float(best[-1, 1]), "error_m": error},
               "history": out.history, "search": {"stop_reason": out.stop_reason},
               "timing": {"wall_s": out.wall_s, "evaluations": out.evaluations + 1,
                          "sim_steps": int(out.totals["sim_steps"]) + nstep}}
    return JobResult(summary=summary, history=out.history, traces={"best": trace}, model_xml=XML,
                     evaluations=out.evaluations + 1, sim_steps=summary["timing"]["sim_steps"])


class BallisticKind(Kind):
    name = "ballistic"
    title = "Ball launched to a target distance (contract test kind)"
    paper = "none: a test fixture of gaitmend's kind contract"
    Spec = BallisticSpec
    robots = {"ball": "a 0.2 kg ball of 5 cm radius on a plane"}
    history_columns = {"generation": "0 = the initial population", "best": "smallest distance error so far (m)",
                       "mean": "mean error of the generation (m)", "worst": "largest error of the generation (m)",
                       "generation_best": "smallest error of the generation (m)",
                       "evaluations": "launches so far"}
    trace_descriptions = {"best": "the best launch"}
    figure_descriptions = {"convergence": "distance error per generation"}

    def run(self, spec, ctx):
        return run(spec, ctx)

    def damage_text(self, spec):
        return f"target {spec.target_m:g} m"

    def headline(self, summary):
        e = summary["best"]["error_m"]
        return [headline_row("distance error", e, "m", "lower", "<= 0.05 m", e <= 0.05),
                headline_row("rest position", summary["best"]["rest_x_m"], "m", None)]

    def summary_tables(self, summary):
        b = summary["best"]
        return [table(f"ball to {summary['target_m']:g} m", ["vx (m/s)", "vz (m/s)", "rests at (m)", "error (m)"],
                      [[f"{b['velocity_m_s'][0]:.3f}", f"{b['velocity_m_s'][1]:.3f}", f"{b['rest_x_m']:.3f}",
                        f"{b['error_m']:.4f}"]], [f"stopped: {summary['search']['stop_reason']}"])]

    def figures(self, result, out_dir):
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(4, 3))
        ax.plot([r["generation"] for r in result.history], [r["best"] for r in result.history])
        ax.set_xlabel("generation")
        ax.set_ylabel("error (m)")
        path = out_dir / "convergence.svg"
        fig.savefig(path)
        plt.close(fig)
        return [path]

    def replay_style(self, trace_names):
        return [ReplayTrack("best", "best launch", "method", 0)] if "best" in trace_names else []

    def smoke_spec(self):
        return {"kind": "ballistic", "search": {"population": 6, "generations": 3, "seed": 5}}

    def experiments(self):
        return [Experiment("launch", "one launch search", Search, lambda p, log: f"population {p.population}")]


KIND = BallisticKind()
