"""The phases of a ``multigait`` job: the state its steps share, the search and its
random-search control, and the controls block.

Every phase counts its work in the units of the spec's ``budget_formula`` (a simulated gait
set, a plan, a re-simulated tree node) and runs as one ``app.jobs.evidence.Phases`` entry:
the search and the control checkpoint after every generation through the shared loop; the
post-search analysis (held-out plans, tree verification, reuse plans, robustness cases)
ticks its phase after every chunk of work, which reports progress and stops on cancel.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from app.jobs.evidence import ControlRow, PhaseContext, Phases
from app.jobs.loop import Generation, run_search
from app.jobs.multigait.planner.costs import evaluate
from app.jobs.multigait.planner.maps import PlanMap
from app.jobs.multigait.planner.primitives import ModularSim
from app.jobs.multigait.spec import MultigaitSpec
from app.robots.modular import Shape


@dataclasses.dataclass
class Job:
    """What every step of one run shares: the problem, its simulator and its phases."""

    spec: MultigaitSpec
    shape: Shape
    pmap: PlanMap
    sim: ModularSim
    lower: np.ndarray
    upper: np.ndarray
    phases: Phases
    _contexts: dict[str, PhaseContext] = dataclasses.field(default_factory=dict)

    @property
    def k(self) -> int:
        return self.spec.k

    @property
    def K(self) -> int:
        return self.spec.iterations

    @property
    def radius(self) -> float:
        return self.shape.radius_mu()

    @property
    def stuck(self) -> tuple[int, ...]:
        return tuple(self.spec.damage.stuck_modules)

    @property
    def sign(self) -> float:
        """+1 for coverage (maximised), -1 for distance: the optimisers maximise fitness."""
        return 1.0 if self.spec.cost == "coverage" else -1.0

    def phase(self, name: str) -> PhaseContext:
        """The phase's context, one per job: its ``done`` is the units the phase used."""
        if name not in self._contexts:
            self._contexts[name] = self.phases.context(name)
        return self._contexts[name]

    def used(self, counted: dict[str, int]) -> dict[str, int]:
        """Units used per phase, in run order: the searches' evaluations (``counted``; a
        phase restored from a checkpoint counts in full), the other phases' ticks."""
        return {name: counted[name] if name in counted else self.phase(name).done for name in self.phases.sizes}


@dataclasses.dataclass
class SearchResult:
    """One search phase, its best in the cost's own units (coverage %, or distance mu)."""

    best_x: np.ndarray
    best_value: float
    history: list[dict[str, Any]]
    evaluations: int
    wall_s: float
    sim_s: float
    plan_s: float
    sim_steps: int
    stop_reason: str
    generations_run: int


def search_phase(job: Job, name: str, opt, generations: int | None = None) -> SearchResult:
    """One ask/tell search through the shared loop (app/jobs/loop.py: generation 0 is the
    initial swarm, ``generations`` more follow) with the job's evaluator (the gait sets
    simulated once, RRT-MP on the search's planner draws); checkpoints in its phase after
    every generation, so a resumed job continues bit-identically. The spec's stop rules
    apply to the search; a control runs the ``generations`` the search ran."""
    spec, sim = job.spec, job.sim

    def generation(x):
        steps0 = sim.sim_steps
        ev = evaluate(sim, x, job.k, job.pmap, job.K, spec.cost, spec.seed, job.radius)
        columns = {"nodes_mean": float(ev.tree.n.mean())}
        if hasattr(opt, "diagnostics"):
            columns |= opt.diagnostics()
        return Generation(ev.fitness, columns, {"sim_steps": sim.sim_steps - steps0, "sim_s": ev.sim_s,
                                                "plan_s": ev.plan_s})

    G = spec.search.generations if generations is None else generations
    out = run_search(opt, generation, G, job.phase(name), spec.stop if name == "search" else None, sign=job.sign)
    t = out.totals
    return SearchResult(best_x=out.best_x, best_value=job.sign * out.best_fitness, history=out.history,
                        evaluations=out.evaluations, wall_s=out.wall_s, sim_s=t.get("sim_s", 0.0),
                        plan_s=t.get("plan_s", 0.0), sim_steps=int(t.get("sim_steps", 0)),
                        stop_reason=out.stop_reason, generations_run=out.generations_run)


def _stats(v: np.ndarray) -> dict[str, float]:
    return {"heldout_mean": float(v.mean()), "heldout_std": float(v.std()), "heldout_min": float(v.min()),
            "heldout_max": float(v.max())}


def controls_block(spec: MultigaitSpec, search: SearchResult, held: np.ndarray, control: SearchResult | None,
                   control_held: np.ndarray | None) -> list[dict]:
    """``summary["controls"]``: the held-out re-scoring of the best, the random search at the
    same budget (with its own best re-scored the same way), and the first generation (the
    swarm's own random start). None is judged by the target (``target_met`` None): they are
    yardsticks for the answer, not answers."""
    unit = "%" if spec.cost == "coverage" else "mu"
    better = "higher" if spec.cost == "coverage" else "lower"
    n = spec.controls.heldout_plans
    ins = search.best_value
    rows = [ControlRow(
        "heldout_rescoring", f"the final best gait set planned again on {n} fresh planner draws held out from selection",
        {"in_sample": ins, **_stats(held), "change": float(held.mean() - ins)}, None, n,
        f"in-sample {ins:.2f} {unit} (the draws the search selected on) vs held-out mean "
        f"{held.mean():.2f} {unit} (std {held.std():.2f}); the held-out value is the one to expect")]
    if control is not None:
        d_in = control.best_value - ins
        d_ho = float(control_held.mean() - held.mean())
        h = control.history
        rows.append(ControlRow(
            "random_search", "random search: gait sets drawn uniformly in the same bounds, same evaluator and "
                             "planner draws, same number of evaluations",
            {"in_sample_best": control.best_value, **_stats(control_held), "first_generation_mean": h[0]["mean"],
             "last_generation_mean": h[-1]["mean"], "search_minus_random_in_sample": -d_in,
             "search_minus_random_heldout": -d_ho}, None, control.evaluations,
            f"random search's best: {control.best_value:.2f} {unit} in-sample, {control_held.mean():.2f} {unit} "
            f"held-out, against the search's {ins:.2f} / {held.mean():.2f} ({better} is better); one seed decides "
            "nothing: the comparison over seeds with its test is in docs/multigait.md"))
    h = search.history
    if h:
        rows.append(ControlRow(
            "first_generation", f"the search's first generation ({spec.search.particles} random gait sets)",
            {"best": h[0]["generation_best"], "mean": h[0]["mean"]}, None, spec.search.particles,
            "the final best is a best of many evaluations and the first generation's mean a mean of few: compare "
            "the final best with the random-search control, not with this mean"))
    return [r.to_json() for r in rows]
