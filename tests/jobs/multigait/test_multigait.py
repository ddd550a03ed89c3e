"""Job kind ``multigait`` (paper 001): spec validation, a small real run with its controls
and robustness, determinism and resume, the budget and cancel in every phase, the
staircase with simulated expansions, plots."""

import copy

import numpy as np
import pytest

from app.jobs.multigait import KIND as multigait
from app.jobs.base import Cancelled, SpecError
from app.jobs.registry import parse_spec
from tests.results.convergence_page import figure_plot, page_plot, saved_figures  # noqa: F401 (fixture)

SMALL = {"kind": "multigait", "robot": "lizard", "search": {"particles": 6, "generations": 4, "seed": 3},
         "planner": {"iterations": 40}, "gait_duration_s": 8.0, "reuse": {"plans": 3, "iterations": 30},
         "verify": {"nodes": 12}}


class Ctx:
    def __init__(self, cancel_after=None, ckpt=None, cancel_in=None):
        self.artifact_dir = None
        self._ckpt = copy.deepcopy(ckpt)
        self.cancel_after = cancel_after
        self.cancel_in = cancel_in  # cancel as soon as this phase reports progress
        self.calls = 0
        self.progress_rows = []
        self.phases = []

    def progress(self, done, total, info):
        self.progress_rows.append((done, total))
        self.phases.append(info.get("phase"))

    def save_checkpoint(self, state):
        self._ckpt = copy.deepcopy(state)

    def load_checkpoint(self):
        return self._ckpt

    def is_cancelled(self):
        self.calls += 1
        if self.cancel_in is not None:
            return bool(self.phases) and self.phases[-1] == self.cancel_in
        return self.cancel_after is not None and self.calls > self.cancel_after


def test_defaults_are_the_papers():
    s = parse_spec({"kind": "multigait"})
    assert s.search.optimizer == "pso" and s.search.particles == 20 and s.search.generations == 150
    assert s.search.pso == "paper"
    assert s.search.pso_coefficients() == {"w": 0.1, "phi1": 2.0, "phi2": 2.0, "vmax": 1.0}
    c = parse_spec({"kind": "multigait", "search": {"pso": "constriction", "w": 0.6}}).search.pso_coefficients()
    assert c == {"w": 0.6, "phi1": 1.49618, "phi2": 1.49618, "vmax": 0.2}
    assert s.k == 3 and s.iterations == 150 and s.gait_duration_s == 30.0
    assert parse_spec({"kind": "multigait", "cost": "distance"}).iterations == 100
    st = parse_spec({"kind": "multigait", "map": "stairs", "cost": "distance"})
    assert st.k == 2 and st.iterations == 150
    # every phase counts: search 20 x (150 + 1) (generation 0 is the initial swarm), random search the
    # same, examine 1, held-out 2 x 20, verify 60, reuse 3 x 20, robustness 6
    assert s.budget_parts() == {"search": 3020, "random_search": 3020, "examine": 1, "heldout": 40, "verify": 60,
                                "reuse": 60, "robustness": 6}
    assert s.evaluations_budget == 6207
    assert st.budget_parts()["verify"] == st.budget_parts()["reuse"] == 0  # nothing composed on the staircase


def test_a_budget_over_the_limit_is_refused_with_its_formula():
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "multigait", "search": {"particles": 1000, "generations": 1500}})
    msg = str(e.value)
    assert "evaluations_budget: 3002167 units exceed the limit of 2000000" in msg
    assert "units of work" in msg and "reuse.plans" in msg and "controls.random_search" in msg
    assert parse_spec({"kind": "multigait", "search": {"particles": 1000, "generations": 1500},
                       "controls": {"random_search": False}}).evaluations_budget == 1501000 + 1 + 20 + 60 + 60 + 6


@pytest.mark.parametrize("bad,field", [
    ({"robot": "snake"}, "robot"),
    ({"map": "moon"}, "map"),
    ({"gaits": 0}, "gaits"),
    ({"search": {"particles": 1}}, "search.particles"),
    ({"search": {"optimizer": "de", "particles": 3}}, "particles"),
    ({"damage": {"stuck_modules": [1, 1]}}, "damage.stuck_modules"),
    ({"damage": {"stuck_modules": [7]}}, "damage.stuck_modules"),
    ({"cost": "speed"}, "cost"),
    ({"planner": {"iterations": 0}}, "planner.iterations"),
    ({"search": {"pso": "clerc"}}, "search.pso"),
    ({"search": {"vmax": 0.0}}, "search.vmax"),
    ({"controls": {"heldout_plans": 0}}, "controls.heldout_plans"),
    ({"robustness": {"enabled": 1}}, "robustness.enabled"),
    ({"colour": "red"}, "colour"),
])
def test_bad_specs_name_the_field(bad, field):
    with pytest.raises(SpecError) as e:
        parse_spec({"kind": "multigait", **bad})
    assert field in str(e.value)


@pytest.fixture(scope="module")
def small_ctx():
    return Ctx()


@pytest.fixture(scope="module")
def small_run(small_ctx):
    spec = parse_spec(SMALL)
    return spec, multigait.run(spec, small_ctx)


def test_small_run_improves_on_its_first_generation(small_run):
    spec, res = small_run
    s = res.summary
    h = res.history
    assert len(h) == 5 and s["timing"]["search_evaluations"] == 30
    assert s["result"]["final_best"] > h[0]["generation_best"] > 0
    assert s["result"]["reproduced"]  # the best gaits planned again give the recorded cost
    assert all(b2 >= b1 for b1, b2 in zip([r["best"] for r in h], [r["best"] for r in h][1:]))
    assert 0 < s["result"]["final_best"] <= 100
    assert s["timing"]["wall_s"] > 0 and "per_generation_s" in s["timing"]
    assert len(s["per_gait"]) == 3 and set(res.traces) >= {"gait1", "gait2", "gait3", "plan", "tree"}
    comp = s["composition"]
    assert comp["depth1_position_error_mu"] < 1e-6 and comp["nodes"] >= 1
    assert set(s["reuse"]) == {"empty_same", "column_same", "column_opposite"}
    tr = res.traces["gait1"]
    assert tr["qpos"].shape[0] == tr["time_s"].shape[0] == tr["com_m"].shape[0]


def test_same_seed_same_numbers_and_resume_is_bit_identical(small_run):
    spec, full = small_run
    ctx = Ctx(cancel_after=2)
    with pytest.raises(Cancelled):
        multigait.run(spec, ctx)
    assert len(ctx._ckpt["search"]["history"]) == 2
    resumed = multigait.run(spec, Ctx(ckpt=ctx._ckpt))
    assert resumed.history == full.history
    assert resumed.summary["best_params"] == full.summary["best_params"]
    assert resumed.summary["tree"] == full.summary["tree"]


def test_other_seed_other_gaits(small_run):
    spec, full = small_run
    other = parse_spec({**SMALL, "search": {**SMALL["search"], "seed": 4, "generations": 1},
                        "reuse": {"enabled": False}, "verify": {"nodes": 0}})
    saved = []
    ctx = Ctx()
    ctx.save_checkpoint = lambda state: saved.append(copy.deepcopy(state))
    res = multigait.run(other, ctx)
    # the search's first swarm is the one PSO draws from seed 4, not the one it draws from the spec's seed 3
    from app.jobs.multigait.run import set_up
    from app.optim.registry import make_optimizer

    job = set_up(other, Ctx())
    job.sim.close()
    s = other.search

    def first_swarm(seed):
        return make_optimizer("pso", job.lower, job.upper, s.particles, seed, **s.pso_coefficients()).ask()

    after_gen0 = saved[0]["search"]["optimizer"]
    assert after_gen0["generation"] == 1
    assert np.array_equal(np.array(after_gen0["pbest"]), first_swarm(4))
    assert (first_swarm(4) != first_swarm(spec.seed)).all()
    # and the answer is the best particle that seed's search saw
    last = [c["search"]["optimizer"] for c in saved if "optimizer" in c.get("search", {})][-1]
    assert res.summary["best_params"]["values"] == pytest.approx(last["pbest"][int(np.argmax(last["pbest_f"]))])


def test_damaged_robot_has_fewer_parameters():
    spec = parse_spec({**SMALL, "damage": {"stuck_modules": [3, 6]}, "search": {"particles": 3, "generations": 1},
                       "reuse": {"enabled": False}, "verify": {"nodes": 0}})
    res = multigait.run(spec, Ctx())
    assert len(res.summary["best_params"]["values"]) == 3 * 6 * 5
    assert 'name="hinge3"' not in res.model_xml and 'name="hinge4"' in res.model_xml


def test_staircase_expansions_are_simulated():
    spec = parse_spec({"kind": "multigait", "robot": "quadropod", "map": "stairs", "cost": "distance",
                       "search": {"particles": 2, "generations": 1}, "planner": {"iterations": 3},
                       "gait_duration_s": 2.0})
    res = multigait.run(spec, Ctx())
    s = res.summary
    assert s["gaits"] == 2 and s["composition"]["note"].startswith("expansions simulated")
    assert s["reuse"] is None
    pos = np.array(s["tree"]["pos_mu"])
    assert pos.shape[0] >= 1 and np.all(np.isfinite(pos))
    # the cost is the 3-D distance from the tree to the goal on the plateau
    goal = np.array(s["map"]["goal"])
    assert s["result"]["final_best"] == pytest.approx(np.linalg.norm(pos - goal, axis=1).min())


def test_plots(small_run, tmp_path, saved_figures):
    """Each figure is written (PNG and SVG) and draws the result's own numbers, each derived
    here from the summary and traces: the history's series, every gait's pivot trace from its
    start, the per-gait bars sorted by distance, the tree's nodes, the composition error per
    node and the reuse means."""
    spec, res = small_run
    s, tr = res.summary, res.traces
    files = multigait.figures(res, tmp_path)
    names = {p.name for p in files}
    for n in ("convergence", "gait_traces", "gait_distance_rotation", "tree_map", "composition_error", "reuse"):
        assert f"{n}.png" in names and f"{n}.svg" in names and (tmp_path / f"{n}.png").stat().st_size > 0

    lines = {ln.get_label(): list(ln.get_ydata()) for ln in saved_figures["convergence.png"].axes[0].get_lines()}
    for key, label in multigait.history_axis(spec.model_dump())["series"].items():
        if any(isinstance(r.get(key), (int, float)) for r in res.history):
            ys = [r.get(key, np.nan) for r in res.history]
            assert np.allclose(lines[label], ys, equal_nan=True), key

    drawn = [ln.get_xydata() for ln in saved_figures["gait_traces.png"].axes[0].get_lines()]
    assert len(drawn) == s["gaits"]
    for j, xy in enumerate(drawn):
        p = np.asarray(tr[f"gait{j + 1}"]["pivot_mu"])
        assert np.allclose(xy, p[:, :2] - p[0, :2])

    dist_ax, rot_ax = saved_figures["gait_distance_rotation.png"].axes
    by_distance = sorted(s["per_gait"], key=lambda r: r["distance_mu"], reverse=True)
    assert [b.get_height() for b in dist_ax.patches] == pytest.approx([r["distance_mu"] for r in by_distance])
    assert [b.get_height() for b in rot_ax.patches] == pytest.approx([abs(r["rotation_deg"]) for r in by_distance])

    tree = tr.get("tree", s["tree"])
    nodes = [ln for ln in saved_figures["tree_map.png"].axes[0].get_lines() if ln.get_marker() == "."]
    assert len(nodes) == 1 and np.allclose(nodes[0].get_xydata(), np.asarray(tree["pos_mu"])[:, :2])

    c = tr["composition"]
    err = np.linalg.norm(np.asarray(c["composed_mu"])[1:, :2] - np.asarray(c["simulated_mu"])[1:, :2], axis=1)
    (err_line,) = saved_figures["composition_error.png"].axes[1].get_lines()
    assert np.allclose(err_line.get_xdata(), np.asarray(c["depth"])[1:]) and np.allclose(err_line.get_ydata(), err)

    for ax, key in zip(saved_figures["reuse.png"].axes, ("distance_mu", "coverage_pct"), strict=True):
        assert [b.get_height() for b in ax.patches] == pytest.approx([v[key]["mean"] for v in s["reuse"].values()])


def test_the_page_shows_each_table_once_and_no_raw_line(small_run):
    """The job page (the kind's views, then its page tables) showed the per-gait table twice
    and, under the search table, the CLI's raw notes ("re-planned cost matches the search:
    True", one "reuse <name>: ..." line per scenario, already the reuse panel)."""
    from app.api.routes.dashboard import _panels_of_tables

    _, res = small_run
    s = res.summary
    panels = list(multigait.views(s, res.traces)) + _panels_of_tables(list(multigait.page_tables(s)))
    gait_rows = [p for p in panels if "table" in p and any("gait" in str(c) for c in p["table"]["columns"][:1])]
    assert [p["id"] for p in gait_rows] == ["per-gait"], [p["title"] for p in gait_rows]
    assert len({p["title"] for p in panels}) == len(panels)
    search = [p for p in panels if p["title"] == "Search: first and final generation"]
    assert len(search) == 1 and search[0]["table"]["rows"][0][2] == f"{s['result']['final_best']:.2f}"
    for p in panels:
        cap = p.get("caption") or ""
        assert "re-planned" not in cap and "reuse " not in cap.lower() and "True" not in cap and "{" not in cap, cap
        assert not any(isinstance(v, (dict, list)) for r in (p.get("table") or {}).get("rows", []) for v in r), p["id"]


def test_controls_and_robustness_are_computed(small_run):
    spec, res = small_run
    s = res.summary
    ctl = {c["name"]: c for c in s["controls"]}
    assert set(ctl) == {"heldout_rescoring", "random_search", "first_generation"}
    for c in ctl.values():
        assert set(c) == {"name", "label", "evaluations", "metrics", "target_met", "note"}
    rs = ctl["random_search"]
    assert rs["evaluations"] == 30  # the search's budget, the same evaluator
    assert len(s["control_history"]) == 5 and s["control_history"][-1]["evaluations"] == 30
    # the control's recorded best is what its history says
    assert rs["metrics"]["in_sample_best"] == s["control_history"][-1]["best"] > 0
    ho = ctl["heldout_rescoring"]
    assert ho["evaluations"] == 20 and ho["metrics"]["in_sample"] == s["result"]["final_best"]
    assert ho["metrics"]["heldout_mean"] == pytest.approx(s["result"]["heldout_mean"])
    assert ho["metrics"]["heldout_min"] <= ho["metrics"]["heldout_mean"] <= ho["metrics"]["heldout_max"]
    assert ctl["first_generation"]["metrics"]["mean"] == s["history"][0]["mean"]
    rob = s["robustness"]
    assert [c["name"] for c in rob["cases"]] == ["dt_half", "dt_quarter", "friction_0.7", "friction_1.3",
                                                 "mass_-10pct", "mass_+10pct"]
    assert rob["total"] == 6 and rob["met"] == sum(c["target_met"] for c in rob["cases"])
    assert rob["spread"]["coverage_pct"]["nominal"] == pytest.approx(s["result"]["final_best"])
    # real re-simulations: the perturbed physics moves the gaits by other distances
    nominal = rob["spread"]["gait_distance_mu"]["nominal"]
    assert all(c["metrics"]["gait_distance_mu"] != nominal for c in rob["cases"])


def test_every_phase_counts_and_progress_covers_them(small_run, small_ctx):
    spec, res = small_run
    b = res.summary["budget"]
    assert b["total"] == spec.evaluations_budget == sum(b["planned"].values())
    assert b["used"]["search"] == b["used"]["random_search"] == 30
    assert b["used"]["heldout"] == 40 and b["used"]["reuse"] == 9 and b["used"]["robustness"] == 6
    assert 1 <= b["used"]["verify"] <= 12
    assert res.evaluations == res.summary["timing"]["evaluations"] == sum(b["used"].values())
    done = [d for d, _ in small_ctx.progress_rows]
    assert all(t == spec.evaluations_budget for _, t in small_ctx.progress_rows)
    assert done == sorted(done) and done[-1] == spec.evaluations_budget
    seen = [p for i, p in enumerate(small_ctx.phases) if p not in small_ctx.phases[:i]]
    assert seen == ["search", "random_search", "examine", "heldout", "verify", "reuse", "robustness", "done"]


@pytest.mark.parametrize("phase", ["random_search", "heldout", "verify", "reuse", "robustness"])
def test_cancel_stops_every_post_search_phase(small_ctx, small_run, phase):
    spec, _ = small_run
    # resume from the finished search's checkpoint, so only the later phases run again
    ckpt = copy.deepcopy(small_ctx._ckpt)
    if phase == "random_search":
        ckpt["random_search"] = None
        ckpt.pop("random_search")
    ctx = Ctx(ckpt=ckpt, cancel_in=phase)
    with pytest.raises(Cancelled):
        multigait.run(spec, ctx)
    assert ctx.phases[-1] == phase  # stopped inside the phase, nothing after it ran
    assert ctx.phases.count(phase) == 1  # at the first unit of work


def test_cancel_in_the_control_then_resume_gives_the_same_result(small_run):
    spec, full = small_run
    ctx = Ctx(cancel_after=7)  # 5 search generations (0-4) + 2 of the random search
    with pytest.raises(Cancelled):
        multigait.run(spec, ctx)
    assert len(ctx._ckpt["search"]["history"]) == 5 and len(ctx._ckpt["random_search"]["history"]) == 2
    resumed = multigait.run(spec, Ctx(ckpt=ctx._ckpt))
    assert resumed.summary["controls"] == full.summary["controls"]
    assert resumed.summary["control_history"] == full.summary["control_history"]


def test_the_bundles_convergence_figure_draws_the_pages_colours(tmp_path):
    """The convergence PNG/SVG used matplotlib's default colours (tab:blue, orange, green)
    where the page draws best in the method's blue, the mean grey, the worst red: both now
    take each series' colour, dash and width from app/core/colors.history_styles, the table
    the page reads (page_table's history and history_lines)."""
    import re

    from app.core.colors import history_styles, page_table
    from app.jobs.multigait.plots import convergence
    from app.jobs.multigait.present import history_axis

    history = [{"generation": g, "best": 2.0 + g, "generation_best": 1.5 + g, "mean": 1.0 + g, "worst": 0.5 + g,
                "random_search_best": 1.8 + g, "random_search_mean": 0.9 + g} for g in range(4)]
    axis = history_axis({"cost": "coverage"})
    page = axis["series"]
    svg = next(p for p in convergence(history, axis, tmp_path) if p.suffix == ".svg").read_text()
    strokes = set(re.findall(r"stroke: (#[0-9a-f]{6})", svg))
    series = list(page)
    styles = history_styles(series)
    assert {c for c, _, _ in styles.values()} <= strokes, (styles, strokes)
    assert not strokes & {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"}, strokes  # matplotlib's own cycle
    # the page's side of the same table (web/static/common.js reads it; job.js colours by it)
    table = page_table()
    for i, k in enumerate(series):
        role = table["history"].get(k)
        colour = table["roles"][role] if role else table["palette"][(i + 2) % len(table["palette"])]
        assert colour == styles[k][0] and list(styles[k][1:]) == table["history_lines"].get(k, ["solid", 2.0]), k


def test_the_page_and_the_figure_draw_the_search_beside_its_random_search(small_run, tmp_path, saved_figures):
    """The bundle's convergence figure drew the random-search control (from the summary's
    control_history) where the page, which plots the history, could not: the control's best
    so far and generation mean now ride in the history beside the search's own columns, and
    the page and the figure draw the same six series from one description
    (present.history_axis, the /views "convergence")."""
    from app.jobs.registry import get_kind

    spec, res = small_run
    for row, control in zip(res.history, res.summary["control_history"], strict=True):
        assert row["generation"] == control["generation"]
        assert (row["random_search_best"], row["random_search_mean"]) == (control["best"], control["mean"])
    kind = get_kind("multigait")
    kind.figures(res, tmp_path)
    page = page_plot(kind.history_axis(spec.model_dump()), res.history)
    assert [t[0] for t in page["traces"]] == list(kind.history_axis({})["series"].values())  # all six
    assert any("random search" in t[0] for t in page["traces"])
    assert figure_plot(saved_figures["convergence.png"]) == page


def test_plan_legend_entry_and_reuse_axis_fit_a_phone():
    """Issue 25 screenshots at 390 px: a 17-gait plan's legend entry ran past the right edge, and
    the reuse chart's 'scenario' title sat on its two-line tick labels."""
    from app.jobs.multigait.views import plan_label, reuse_view

    long = plan_label([1, 1, 3, 2] * 4 + [3])
    lines = long.split("<br>")
    assert len(lines) == 4 and max(len(x) for x in lines) <= len("1 → ") * 6 + 1, lines
    assert "".join(lines).replace(" ", "").replace("→", "").endswith("3)")
    assert plan_label([1, 2, 3]) == "plan (3 gaits: 1 → 2 → 3)"
    stat = {"mean": 1.0, "std": 0.1}
    fig = reuse_view({"reuse": {"empty_same": {"distance_mu": stat, "coverage_pct": stat}}})[1]["figure"]
    assert fig["layout"]["xaxis"]["automargin"] and fig["layout"]["xaxis"]["title"]["standoff"] > 0
