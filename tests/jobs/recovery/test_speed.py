"""Issue 22: walks cut short once they cannot win DE's selection (or beat the random-search
control's best so far), the stop rule on the recovery target (confirmed at half the step),
and the fast preset."""

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from app.jobs.base import MemoryContext
from app.jobs.loop import Generation, GoalCheck, StopRules, run_search
from app.jobs.recovery.metrics import fitness, fitness_bound
from app.jobs.recovery.run import run
from app.jobs.recovery.spec import PRESETS, RecoverySpec
from app.jobs.registry import parse_spec
from app.optim.de import DifferentialEvolution
from app.optim.random_search import RandomSearch

W = [1.0, 1.0, 10.0, 100.0, 100.0]


@pytest.mark.parametrize("units", ["cm_deg", "m_rad"])
def test_the_bound_is_never_below_the_fitness_it_bounds(units):
    rng = np.random.default_rng(0)
    n = 5000
    m = {"y_f_m": rng.uniform(-0.5, 1.5, n), "x_f_m": rng.normal(0, 0.1, n), "yaw_f_deg": rng.normal(0, 20, n),
         "roll_amp_deg": rng.uniform(0, 8, n), "pitch_amp_deg": rng.uniform(0, 8, n), "fell": rng.random(n) < 0.1}
    f = fitness(m, W, units)
    # any reach at least the final forward displacement, amplitudes at most the final ones
    reach = m["y_f_m"] + rng.uniform(0, 0.3, n)
    b = fitness_bound(reach, m["roll_amp_deg"] * rng.uniform(0, 1, n), m["pitch_amp_deg"] * rng.uniform(0, 1, n),
                      W, units)
    assert np.all(b >= f)


def _search(cut: bool, **extra) -> dict:
    spec = RecoverySpec(damage={"lost_legs": [1, 6]}, search={"population": 8, "generations": 4, "seed": 2,
                                                             "cut_walks": cut},
                        sim={"duration_s": 4.0}, controls={"random_search": False}, robustness={"cases": []}, **extra)
    return run(spec, MemoryContext()).summary


@pytest.fixture(scope="module")
def full_and_cut():
    return _search(False), _search(True)


def test_cut_walks_give_the_answer_of_the_full_walks_for_fewer_steps(full_and_cut):
    full, cut = full_and_cut
    assert cut["best"]["params"] == full["best"]["params"] and cut["best"]["fitness"] == full["best"]["fitness"]
    assert [r["best"] for r in cut["history"]] == [r["best"] for r in full["history"]]
    cuts = [r["cut"] for r in cut["history"][1:]]
    assert sum(cuts) > 0 and cut["history"][0]["cut"] == 0  # generation 0 has no parents to lose against
    assert len({tuple(r) for r in cut["history"]}) == 1  # one set of columns: the bundle's history.csv
    assert cut["timing"]["sim_steps"] < full["timing"]["sim_steps"]
    assert cut["timing"]["evaluations"] == full["timing"]["evaluations"]  # a cut walk still counts


def test_de_and_random_search_hand_out_thresholds():
    de = DifferentialEvolution(np.zeros(3), np.ones(3), population=5, seed=0)
    de.ask()
    assert de.selection_thresholds() is None  # generation 0: no parents
    de.tell(np.arange(5.0))
    de.ask()
    np.testing.assert_array_equal(de.selection_thresholds(), np.arange(5.0))
    rnd = RandomSearch(np.zeros(3), np.ones(3), population=4, seed=0)
    rnd.ask()
    assert rnd.selection_thresholds() is None  # nothing told: no best to beat
    rnd.tell(np.array([1.0, 3.0, 2.0, -1.0]))
    assert rnd.selection_thresholds() is None  # nothing asked
    rnd.ask()
    np.testing.assert_array_equal(rnd.selection_thresholds(), np.full(4, 3.0))  # the best so far, for every draw


def test_the_control_with_cut_walks_keeps_the_full_walks_best_for_fewer_steps():
    from app.jobs.recovery.run import random_control, set_up

    spec = RecoverySpec(damage={"lost_legs": [1, 6]}, search={"population": 8, "generations": 4, "seed": 3},
                        sim={"duration_s": 4.0}, robustness={"cases": [], "held_out": 0})
    assert spec.controls.cut_walks  # on by default
    job = set_up(spec)
    try:
        cut, full = (random_control(job, 4, MemoryContext(), cuts=c) for c in (True, False))
    finally:
        job.close()
    assert np.array_equal(cut.best_x, full.best_x) and cut.best_fitness == full.best_fitness
    assert [r["best"] for r in cut.history] == [r["best"] for r in full.history]
    assert cut.history[0]["cut"] == 0 and sum(r["cut"] for r in cut.history) > 0  # nothing to beat in generation 0
    assert "cut" not in full.history[0]
    assert cut.totals["sim_steps"] < full.totals["sim_steps"] and cut.evaluations == full.evaluations


class _Toy:
    """A deterministic ask/tell optimiser over one coordinate: generation g asks [g, g/2]."""

    def __init__(self):
        self.generation, self._best = 0, (np.zeros(1), -np.inf)

    def ask(self):
        return np.array([[float(self.generation)], [self.generation / 2.0]])

    def tell(self, f):
        x = self.ask()
        i = int(np.argmax(f))
        if f[i] > self._best[1]:
            self._best = (x[i].copy(), float(f[i]))
        self.generation += 1

    @property
    def best(self):
        return self._best

    def state(self):
        return {"generation": self.generation, "x": self._best[0].tolist(), "f": self._best[1]}

    def restore(self, s):
        self.generation, self._best = s["generation"], (np.asarray(s["x"]), s["f"])


class _Ctx(MemoryContext):
    def __init__(self, ckpt=None, kill_after=None):
        super().__init__()
        self._ck, self.saves, self.kill_after = ckpt, 0, kill_after

    def save_checkpoint(self, state):
        self._ck = json.loads(json.dumps(state))
        self.saves += 1
        if self.kill_after is not None and self.saves >= self.kill_after:
            raise KeyboardInterrupt

    def load_checkpoint(self):
        return copy.deepcopy(self._ck)


def _goal_run(ctx, asked):
    def goal(x):
        asked.append(float(x[0]))
        return GoalCheck(bool(x[0] >= 3), evaluations=1, totals={"sim_steps": 7})

    return run_search(_Toy(), lambda x: Generation(x[:, 0].copy(), totals={"sim_steps": 10}), 10, ctx,
                      goal=goal, stop_at_goal=True)


def test_the_goal_stops_the_search_is_asked_once_per_new_best_and_resumes():
    asked = []
    out = _goal_run(_Ctx(), asked)
    assert out.stop_reason == "target_met" and out.generations_run == 4 and asked == [0.0, 1.0, 2.0, 3.0]
    assert [r["target_met"] for r in out.history] == [0, 0, 0, 1] and out.time_to_target_s is not None
    assert out.evaluations == 4 * 2 + 4 and out.totals["sim_steps"] == 4 * 10 + 4 * 7
    killed = _Ctx(kill_after=2)
    with pytest.raises(KeyboardInterrupt):
        _goal_run(killed, [])
    again = []
    resumed = _goal_run(_Ctx(ckpt=killed.load_checkpoint()), again)
    assert again == [2.0, 3.0] and resumed.history == out.history and resumed.evaluations == out.evaluations


def test_the_fast_preset_fills_what_the_spec_leaves_out_and_round_trips():
    s = parse_spec({"kind": "recovery", "preset": "fast", "stop": {"plateau_generations": 4}})
    assert s.stop.at_target and s.search.cut_walks and s.stop.plateau_generations == 4
    assert parse_spec(s.model_dump(mode="json")) == s
    paper = parse_spec({"kind": "recovery"})
    assert paper.preset == "paper" and not paper.stop.at_target and not paper.search.cut_walks
    assert paper == parse_spec({"kind": "recovery", "preset": "paper"})
    assert set(PRESETS) == {"paper", "fast"}
    prop = RecoverySpec.model_json_schema()["properties"]["preset"]
    assert prop["default"] == "paper" and "fast" in prop["description"]


def test_a_search_stopped_at_the_target_met_it_at_half_the_step(tmp_path):
    """Leg 1 lost: the nominal tripod already meets the target, so a small search finds
    such a gait at once; the stop is confirmed by a walk at half the step."""
    spec = parse_spec({"kind": "recovery", "damage": {"lost_legs": [1]}, "preset": "fast",
                       "search": {"population": 6, "generations": 6, "seed": 0},
                       "controls": {"random_search": False}, "robustness": {"cases": ["dt_half"]}})
    s = run(spec, MemoryContext()).summary
    assert s["search"]["stop_reason"] == "target_met" and s["best"]["target_met"]
    assert s["search"]["target_generation"] == s["search"]["generations_run"] - 1
    assert s["timing"]["time_to_target_s"] > 0
    half = s["robustness"]["cases"][0]
    assert half["name"] == "dt_half" and half["target_met"]
    assert s["timing"]["evaluations"] <= spec.evaluations_budget


@pytest.mark.slow
def test_the_quick_bench_names_every_figure_of_the_issue():
    from app.jobs.recovery.reproduce.bench import bench_recovery

    f = bench_recovery(quick=True, log=lambda _: None)
    for key in ("raw_steps_per_s", "evaluator_steps_per_s", "ratio", "paper_recovery_wall_s",
                "time_to_target_median_s", "equal_quality_wall_s", "bench_wall_s"):
        assert key in f
    assert len(f["fast"]["runs"]) == 4 and set(f["peers"]) == {"scipy_de", "cmaes"}
    assert f["paper"]["evaluations"] > 0 and f["equal_quality"]["paper_fitness"] == f["paper"]["fitness"]
    json.dumps(f)


def test_the_bench_measures_the_recommended_modes_cost_on_todays_default_job():
    """(h) issue 47: today's default job and the same spec in the recommended mode, every
    phase, back to back; the recommended job walks more (the robust choice's walks and the
    answer again without the correction)."""
    from app.jobs.recovery.reproduce.bench import recommended_cost

    f = recommended_cost(quick=True)
    assert f["recommended_cost_ratio"] == pytest.approx(f["recommended_job_wall_s"] / f["default_job_wall_s"])
    assert f["recommended"]["evaluations"] > f["default"]["evaluations"]
    assert f["default"]["held_out_met"].endswith("/20") and f["recommended"]["held_out_met"].endswith("/20")
    json.dumps(f)


def test_the_speed_page_renders_from_its_rows():
    from app.jobs.recovery.reproduce import speed_measurements as speed

    run_row = {"lost_legs": [1, 6], "seed": 0, "fitness": 12.0, "target_met": True, "half_step_met": True,
               "search": {"stop_reason": "generations", "generations_run": 61}, "evaluations": 1830,
               "sim_steps": 18_000_000, "cut_steps_saved": 1_000_000, "time_to_target_s": None, "wall_s": 170.0,
               "load": 1.0, "identical_to_documented": True, "curve": [[0, 1.0, 30], [20, 8.0, 630], [60, 12.0, 1830]]}
    equal = {"search": speed.EQUAL["search"] | {"seed": 0}}
    rows = [run_row | {"part": "paper"}, run_row | {"part": "equal", "fitness": 12.5, "sim_steps": 6_000_000,
                                                    "evaluations": 700, "spec": equal,
                                                    "cut_steps_saved": 0, "identical_to_documented": None},
            run_row | {"part": "fast", "sim_steps": 400_000, "time_to_target_s": 4.0,
                       "search": {"stop_reason": "target_met", "generations_run": 2}}]
    md = speed.speed_markdown(rows, Path("/nonexistent"))
    # the paper DE's F at the equal-quality search's steps: 6 M of its 19 M (cut ones included) is
    # 578 of its 1830 walks, before its curve's 630th walk
    assert "| legs 1 & 6 | 12.00 [12.00, 12.00] (1) | 12.50 [12.50, 12.50] (1) | 1 of 1 | 1.00 [1.00, 1.00] (1) | " \
           "1 (1) of 1 | 0.32 |" in md
    assert "(= docs)" in md and "48x fewer" in md
    assert "legs 1 & 6, 1 seeds: median 6,000,000 steps against the paper DE's 19,000,000 (3.2x fewer), median F " \
           "12.50 against 12.00 on the same 1 seeds: equal quality" in md
    # an equal-quality run of a seed the paper DE has no F for is left out of the F comparison
    more = speed.speed_markdown(rows + [rows[1] | {"seed": 1, "fitness": 1.0}], Path("/nonexistent"))
    assert "legs 1 & 6, 2 seeds: median 6,000,000 steps" in more
    assert "median F 12.50 against 12.00 on the same 1 seeds: equal quality" in more
    assert "Other configurations" not in md  # no alternative run, no table
    alt = run_row | {"part": "alt_cmaes_8x90", "fitness": 11.0, "identical_to_documented": None,
                     "half_step_met": False, "spec": {"search": speed.ALTERNATIVES["cmaes_8x90"]["search"] | {"seed": 0}}}
    md = speed.speed_markdown(rows + [alt, alt | {"seed": 1, "fitness": 13.0}], Path("/nonexistent"))
    assert ('| legs 1 & 6 | `{"search": {"optimizer": "cmaes", "population": 8, "generations": 90}}` | 728 (18.00 M) | '
            "12.00 [11.00, 13.00] (2) | 12.00 [12.00, 12.00] (1) | 0 of 1 | 2 (0) of 2 |") in md
    assert "| legs 1 & 6 | `" + json.dumps(speed.EQUAL) + "` | 1008 (6.00 M) | 12.50 [12.50, 12.50] (1) |" in md
    assert "## Short walks" not in md  # no same-steps run beside them, no section
    # a run is labelled by the configuration it ran: an "equal" run of another configuration
    # (the equal-quality one of its time) shows as that alternative, whatever its label said
    old = rows[1] | {"spec": {"search": speed.ALTERNATIVES["cmaes_12x60"]["search"] | {"seed": 0}}}
    md = speed.speed_markdown([rows[0], old, rows[2], alt], Path("/nonexistent"))
    assert '| legs 1 & 6 | `{"search": {"optimizer": "cmaes", "population": 12, "generations": 60}}` | 732 (6.00 M) |' in md
    assert "| legs 1 & 6 | `" + json.dumps(speed.EQUAL) + "` |" not in md
    # short walks (the equal-quality configuration: rows[1] is its seed 0) against CMA-ES 12 x 60
    # with full walks on the same seeds (its steps), 12 x 82 (none here) and the paper DE; the
    # seed that has no same-steps run is left out
    def cfg_row(cfg, seed, f, steps):
        return run_row | {"part": "alt_x", "seed": seed, "fitness": f, "sim_steps": steps,
                          "spec": {"search": cfg["search"] | {"seed": seed}}}

    tried = [cfg_row(speed.EQUAL, k, f, 7_700_000) for k, f in ((1, 12.0), (2, 14.0))]
    tried += [cfg_row(speed.ALTERNATIVES["cmaes_12x60"], k, f, 7_600_000) for k, f in ((0, 12.5), (1, 11.0))]
    md = speed.speed_markdown(rows + tried + [rows[0] | {"seed": 1, "fitness": 11.0}], Path("/nonexistent"))
    assert ("| legs 1 & 6 | short walks | 2 | 12.25 [12.00, 12.50] | 11.75 [11.00, 12.50] | - | 11.50 [11.00, 12.00] | "
            "6.85 M / 7.60 M / - | 170 [170, 170] | 2 (2) of 2 | 2 of 2 |") in md
    assert "- legs 1 & 6: short walks minus CMA-ES 12 x 60 with full walks, paired by seed: +0.50 " in md
    assert "- legs 1 & 6: short walks minus the paper DE, paired by seed: +0.75 " in md
    assert "short walks, own F" not in md  # that variant has no run here
    # the step's settings: one row per change, each against the one before it
    names = list(speed.STEP_SETTINGS)
    settings = {"part": "pairs", "damages": [{"lost_legs": [1, 6], "us_per_step": dict(zip(names, (13.2, 12.0, 11.0)))}],
                "answers": 63, "identical": dict.fromkeys(names, True) | {names[2]: False}, "load": 0.5}
    md = speed.speed_markdown(rows + [settings], Path("/nonexistent"))
    assert "legs 1 & 6 13.2 -> 12.0 us (1.10x) (load 0.5); the 63 documented answers bit-identical to before" in md
    assert "legs 1 & 6 12.0 -> 11.0 us (1.09x) (load 0.5); the 63 documented answers **not** identical" in md
    # where the paper DE's time goes: shares and rates from the row, the paper DE's steps from its runs
    scaling = {"part": "scaling", "generations": 5, "population": 30, "wall_s": 10.0, "in_rollout_s": 9.0,
               "sim_steps": 1_500_000, "threads": 2, "one_thread_steps_per_s": 90_000.0,
               "threads_steps_per_s": 160_000.0, "load": 0.5, "cores": 2}
    md = speed.speed_markdown(rows + [scaling], Path("/nonexistent"))
    assert ("spent 90.0 % of its 10.0 s inside `mujoco.rollout`, at 166,667 steps/s there and 150,000 overall" in md
            and "the threads scale 1.78x" in md and "simulates 19.00 M steps (median of its runs below): 127 s" in md)
    # every run names the host it ran on where it recorded it (wall times differ between hosts)
    host = {"cpu": "AMD EPYC", "cpu_family": 26, "cpu_model": 2, "cores": 2, "python": "3.11"}
    md = speed.speed_markdown([rows[0] | {"machine": host}] + rows[1:], Path("/nonexistent"))
    assert "| 170 | 1.0 | AMD EPYC, family 26 model 2 |" in md and "| 170 | 1.0 | not recorded |" in md
    # the control with cut walks against full walks: a gains row and its own table
    control = {"part": "control", "lost_legs": [3, 4], "seed": 1, "identical": True, "documented_fitness": None,
               "cut": {"fitness": 16.5, "sim_steps": 5_000_000, "walks_cut": 1500, "wall_s": 30.0},
               "full": {"fitness": 16.5, "sim_steps": 15_000_000, "wall_s": 75.0}, "load": 1.5}
    md = speed.speed_markdown(rows + [control, control | {"seed": 2, "identical": False, "documented_fitness": 17.0}],
                              Path("/nonexistent"))
    assert ("1 of 2 controls (30 x 60) the same best as with full walks, bit for bit; 10,000,000 steps against "
            "30,000,000 (3.0x fewer), 60 s against 150 s in all") in md
    assert "| legs 3 & 4 | 1 | yes | 16.50 | 5,000,000 / 15,000,000 | 1500 | 30 / 75 | 1.5 | - |" in md
    assert "| legs 3 & 4 | 2 | **no** | 16.50 | 5,000,000 / 15,000,000 | 1500 | 30 / 75 | 1.5 | 17.00 |" in md


def test_the_equal_quality_comparison_is_also_paired_by_seed():
    """Beside the medians the issue's rule compares, the paired test (app/jobs/stats.py) on
    the seeds both ran: a median above the paper DE's on a few seeds is no difference shown,
    and a clear one is shown; a damage with a single pair gets no line."""
    from app.jobs.recovery.reproduce import speed_measurements as speed

    def run(part, lost, seed, f):
        return {"part": part, "lost_legs": list(lost), "seed": seed, "fitness": f}

    close = [run("paper", (1, 6), s, f) for s, f in enumerate([12.0, 13.0, 14.0, 12.5, 13.5, 12.8])]
    close += [run("equal", (1, 6), s, f) for s, f in enumerate([12.5, 12.0, 14.5, 13.0, 13.2, 13.3])]
    clear = [run("paper", (4,), s, 20.0 + s) for s in range(6)] + [run("equal", (4,), s, 30.0 + s) for s in range(6)]
    one = [run("paper", (3, 4), 0, 20.0), run("equal", (3, 4), 0, 25.0)]
    md = "\n".join(speed.paired_markdown(close + clear + one, []))
    assert "- legs 1 & 6: median F 13.10 against 12.90 (reaches the paper DE's); equal quality minus paper DE, " \
           "paired by seed: +0.12 [" in md and "n = 6: **not shown**." in md
    assert "- leg 4: median F 32.50 against 22.50 (reaches the paper DE's)" in md
    assert "Wilcoxon p = 0.0312, n = 6: **equal quality better (shown)**." in md
    assert "legs 3 & 4" not in md and speed.paired_markdown(one, []) == []


def test_every_alternative_configuration_is_a_part_the_command_accepts():
    from pydantic import ValidationError

    from app.jobs.recovery.reproduce.experiments import SpeedParams
    from app.jobs.recovery.reproduce.speed_measurements import ALTERNATIVES, PARTS

    for name in ALTERNATIVES:
        assert f"alt_{name}" in PARTS
        assert SpeedParams(parts=f"equal,alt_{name}", damages="3-4").parts.endswith(name)
    with pytest.raises(ValidationError):
        SpeedParams(parts="alt_unknown")


def test_the_scaling_part_times_the_rollout_inside_a_real_search():
    from app.jobs.recovery.reproduce import speed_measurements as speed

    r = speed.scaling_row(generations=1, reps=1)
    assert r["sim_steps"] > 30 * 10_000  # two generations of 30 walks, most of them whole
    assert 0 < r["in_rollout_s"] < r["wall_s"]
    assert r["one_thread_steps_per_s"] > 0 and r["threads_steps_per_s"] > 0 and r["threads"] >= 1
    json.dumps(r)


# -- short walks in the first generations (search.short_walks) ------------------------------------

SHORT_SEARCH = {"optimizer": "cmaes", "population": 6, "generations": 4, "seed": 1,
                "short_walks": {"walk_s": 3.0, "generations": 2}}


def _short(**search) -> RecoverySpec:
    return RecoverySpec(damage={"lost_legs": [1, 6]}, search=SHORT_SEARCH | search, sim={"duration_s": 4.0},
                        controls={"random_search": False}, robustness={"cases": [], "held_out": 0})


@pytest.fixture(scope="module")
def short_run():
    return run(_short(), MemoryContext()).summary


def test_short_walks_only_rank_the_first_generations_and_the_answer_is_a_full_walk(short_run):
    s, full_run = short_run, run(_short(short_walks=None), MemoryContext()).summary
    h = s["history"]
    assert [r["walk_s"] for r in h] == [3.0, 3.0, 4.0, 4.0, 4.0]
    assert [r.get("provisional", 0) for r in h] == [1, 1, 0, 0, 0]
    assert len({tuple(r) for r in h[2:]}) == 1 and set(h[0]) == set(h[2]) | {"provisional"}
    full = h[2:]
    # the answer: the best full walk, walked again on its own (same F bit for bit); the short
    # walks' F never competes with it, though the best column shows theirs while they run
    assert s["best"]["fitness"] == max(r["generation_best"] for r in full)
    assert [r["best"] for r in h[:2]] == [h[0]["generation_best"], max(r["generation_best"] for r in h[:2])]
    assert full[0]["best"] == full[0]["generation_best"]
    assert s["timing"]["evaluations"] == full_run["timing"]["evaluations"] == 6 * 5 + 2  # + best and baseline
    assert s["timing"]["sim_steps"] < full_run["timing"]["sim_steps"]
    assert h[0]["mean"] != full_run["history"][0]["mean"]  # the same draws, walked shorter


def test_a_short_walk_is_scored_on_its_displacements_carried_to_the_full_walk():
    """extrapolate: forward, lateral and yaw times sim.duration_s / walk_s before F (the
    metrics kept as walked); without it, the short walk's own F."""
    from app.jobs.recovery.run import _short_scorer, set_up

    rng = np.random.default_rng(4)
    for extrapolate, stretch in ((True, 4.0 / 3.0), (False, 1.0)):
        spec = _short(short_walks={"walk_s": 3.0, "generations": 2, "extrapolate": extrapolate})
        job = set_up(spec)
        scorer = _short_scorer(job)
        try:
            x = job.lower + rng.random((4, job.lower.size)) * (job.upper - job.lower)
            f, m, steps, _ = scorer(x)
        finally:
            scorer.close()
            job.close()
        assert steps <= 4 * 3500 and np.all(m["y_f_m"] != 0)
        moved = m | {k: m[k] * stretch for k in ("y_f_m", "x_f_m", "yaw_f_deg")}
        np.testing.assert_array_equal(f, fitness(moved, spec.objective.weights, spec.objective.units))


@pytest.mark.parametrize("after", [1, 3])
def test_a_search_with_short_walks_resumes_bit_identically(short_run, after):
    """Killed in the short walks' generations, or in the full walks' after them."""
    ctx = _Ctx(kill_after=after)
    with pytest.raises(KeyboardInterrupt):
        run(_short(), ctx)
    resumed = run(_short(), _Ctx(ckpt=ctx.load_checkpoint())).summary
    for key in ("best", "history", "search"):
        assert resumed[key] == short_run[key]


@pytest.mark.parametrize("patch, field, words", [
    ({"optimizer": "de"}, "search.short_walks", "CMA-ES only"),
    ({"short_walks": {"walk_s": 4.0, "generations": 2}}, "search.short_walks.walk_s", "shorter than sim.duration_s"),
    ({"short_walks": {"walk_s": 2.0, "generations": 2}}, "search.short_walks.walk_s", "greater than or equal to 3"),
    ({"short_walks": {"walk_s": 3.0, "generations": 5}}, "search.short_walks.generations", "at most search.generations"),
    ({"short_walks": {"walk_s": 3.0, "generations": 0}}, "search.short_walks.generations", "greater than or equal"),
    ({"short_walks": {"walk_s": "3", "generations": 2}}, "search.short_walks.walk_s", ""),
])
def test_bad_short_walks_name_the_field_and_the_range(patch, field, words):
    from app.jobs.base import SpecError

    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "recovery", "search": SHORT_SEARCH | patch, "sim": {"duration_s": 4.0}})
    err = e.value.errors[0]
    # a range is the field's own error; a rule across fields is the spec's, named in its message
    assert words in err["message"]
    assert err["field"] == field or (err["field"] == "spec" and err["message"].startswith(field + ":"))


def test_short_walks_refuse_what_judges_the_best_while_they_run():
    from app.jobs.base import SpecError

    for extra, name in (({"preset": "fast"}, "stop.at_target"), ({"robust": {"models": ["dt_half"]}}, "robust")):
        with pytest.raises(SpecError) as e:
            parse_spec({"kind": "recovery", "search": SHORT_SEARCH, "sim": {"duration_s": 4.0}} | extra)
        msg = e.value.errors[0]["message"]
        assert msg.startswith("search.short_walks: not with") and name in msg


class _Provisional(_Toy):
    """_Toy, told its first two generations as provisional: they do not count for the best."""

    def tell(self, f, provisional=False):
        if provisional:
            self.generation += 1
        else:
            super().tell(f)


def test_the_stop_rules_and_the_best_pass_over_provisional_rows():
    """The first two generations score 100 (above the target and flat: a plateau) but are
    provisional: nothing stops there and the best is of the later rows only."""
    def evaluate(x):
        g = int(x[0, 0])
        return Generation(np.full(2, 100.0) if g < 2 else x[:, 0].copy(), provisional=g < 2)

    out = run_search(_Provisional(), evaluate, 5, MemoryContext(),
                     StopRules(target=50.0, plateau_generations=1, plateau_rel_tol=0.0))
    assert [r.get("provisional", 0) for r in out.history[:3]] == [1, 1, 0]
    assert [r["best"] for r in out.history] == [100.0, 100.0, 2.0, 3.0, 4.0, 5.0]
    assert out.stop_reason == "generations" and out.best_fitness == 5.0


def test_the_perturbed_part_judges_each_answer_as_a_job_judges_its_own():
    """The answers of the short walks, their same-steps control and the paper DE (Table II's
    for the seed), re-walked under the named cases and the seed's held-out models: each
    case's verdict is the one Table II's job recorded for that answer, and the held-out count
    is what a job's held-out block (robust.held_out) gives the same answer and seed."""
    from app.jobs.recovery.reproduce import speed_measurements as speed
    from app.jobs.recovery.metrics import target_met
    from app.jobs.recovery.robust import held_out
    from app.jobs.recovery.run import set_up

    table2 = speed._table2_rows(Path("docs"))
    doc = {k: speed._documented((1, 6), k, table2) for k in (0, 1, 2)}

    def answer(part, cfg, of):  # seed 0's run of ``cfg`` holding the documented answer of seed ``of``
        return {"part": part, "lost_legs": [1, 6], "seed": 0, "params": doc[of]["best_params"],
                "spec": {"search": cfg["search"] | {"seed": 0}}}

    rows = [answer("equal", speed.EQUAL, 1), answer("alt_x", speed.ALTERNATIVES["cmaes_12x60"], 2)]
    [row] = list(speed.perturbed_rows(rows, table2, [(1, 6)], set()))
    assert row["seed"] == 0 and row["cases"] == list(doc[0]["robustness"]["cases"])
    job = set_up(RecoverySpec(damage={"lost_legs": [1, 6]}))
    try:
        for name, of in zip(speed.PERTURBED_SETS, (1, 2, 0)):
            assert row["sets"][name]["cases_met"] == [bool(c["target_met"]) for c in
                                                     doc[of]["robustness"]["cases"].values()]
            x = np.array(list(doc[of]["best_params"].values()))
            block, _ = held_out(job.mspec, job.robot, job.seq, job.ev.cfg, x, 0, 20, target_met)
            assert row["sets"][name]["held_out_met"] == block["met"]
    finally:
        job.close()
    assert list(speed.perturbed_rows(rows, table2, [(1, 6)], {((1, 6), 0)})) == []  # done: not walked again
    # the page: counts per case and held-out, then the short walks paired by seed with each control
    other = copy.deepcopy(row) | {"seed": 1}
    other["sets"]["paper DE"]["held_out_met"] += 5
    md = "\n".join(speed.perturbed_markdown([row, other]))
    met = row["sets"]["short walks"]
    assert ("| legs 1 & 6 | short walks | 2 | " + " | ".join(f"{2 * m} of 2" for m in met["cases_met"])
            + f" | {2 * met['held_out_met']} of 40 (median {met['held_out_met']:g}) |") in md
    assert "- legs 1 & 6: models met (of 27), short walks minus paper DE, paired by seed: " in md
    assert speed.perturbed_markdown([]) == []
    # a control shown better is named in the verdict under the table
    worse = [copy.deepcopy(row) | {"seed": k} for k in range(8)]
    for r in worse:  # the same-steps control as robust as the short walks, the paper DE more
        r["sets"]["CMA-ES 12 x 60, full walks (same steps)"] = dict(r["sets"]["short walks"])
        r["sets"]["paper DE"]["held_out_met"] = r["sets"]["short walks"]["held_out_met"] + 3 + r["seed"] % 2
    md = "\n".join(speed.perturbed_markdown(worse))
    assert "shown less robust on legs 1 & 6 (against paper DE), and no difference is shown elsewhere." in md
    assert "no difference from either control is shown" in "\n".join(speed.perturbed_markdown([row, other]))
