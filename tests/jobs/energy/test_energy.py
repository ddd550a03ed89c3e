"""The ``energy`` kind: strict specs with physical bounds, determinism and a bit-identical
resume, the result's evidence sections."""

import json
from pathlib import Path

import pytest

from app.jobs.base import Cancelled, SpecError, dumps
from app.jobs.energy.run import run
from app.jobs.energy.spec import EnergySpec

CHEAP = {"search": {"population": 4, "generations": 2, "workers": 1}, "model": {"knots": 48},
         "physics": {"periods": 1}, "evidence": {"controls": False, "robustness": False}}


class Ctx:
    """The run context a worker hands a kind, with an in-memory checkpoint store."""

    def __init__(self, tmp: Path, checkpoint=None, cancel_after_saves=None):
        self.artifact_dir = tmp
        self.ckpt = checkpoint
        self.cancel_after = cancel_after_saves
        self.saves = 0
        self.progress_log = []

    def progress(self, done, total, info):
        self.progress_log.append((done, total))

    def save_checkpoint(self, state):
        self.ckpt = json.loads(json.dumps(state))  # what a store round trip keeps
        self.saves += 1

    def load_checkpoint(self):
        return self.ckpt

    def is_cancelled(self):
        return self.cancel_after is not None and self.saves >= self.cancel_after


def _field_errors(data):
    with pytest.raises(SpecError) as e:
        EnergySpec.parse({"kind": "energy"} | data)
    return [(err["field"], err["message"]) for err in e.value.errors]


@pytest.mark.parametrize("data, field", [
    ({"gait": {"duty": [0.5, 0.5, 1.0, 0.5]}}, "gait.duty"),
    ({"gait": {"duty": [0.0, 0.5, 0.5, 0.5], "family": "free"}}, "gait.duty"),
    ({"task": {"speed_m_s": -1.0}}, "task.speed_m_s"),
    ({"task": {"speed_m_s": "1.0"}}, "task.speed_m_s"),  # no coercion
    ({"task": {"friction": float("nan")}}, "task.friction"),
    ({"design": {"links_m": [0.06, 0.2, 0.2]}}, "design.links_m"),
    ({"search": {"population": 41}}, "search.population"),
    ({"search": {"populaton": 40}}, "search.populaton"),
    ({"model": {"knots": 97}}, "model.knots"),
    ({"gait": {"touchdown_s": [0.0, 0.1, 0.23, 0.0]}}, "gait"),
    ({"gait": {"duty": [0.5, 0.5, 0.5]}}, "gait.duty"),
    ({"task": {"height_m": 0.75}}, "design.links_m"),  # Table 1's legs cannot reach that high
])
def test_bad_specs_name_their_field(data, field):
    errors = _field_errors(data)
    assert any(f == field for f, m in errors), errors


def test_defaults_are_table1():
    s = EnergySpec()
    assert (s.task.speed_m_s, s.task.height_m, s.task.swing_height_m) == (1.0, 0.5, 0.25)
    assert s.gait.period_s == 0.46 and s.gait.touchdown_s == [0.0, 0.23, 0.23, 0.0]
    assert s.design.links_m == [0.06, 0.33, 0.33]
    assert s.evaluations_budget == 2 * 40 * 41 + 1 + 7 + 2 + 6


def test_run_is_deterministic_and_resumes_bit_identically(tmp_path):
    spec = EnergySpec.parse(CHEAP)
    a = run(spec, Ctx(tmp_path))
    with pytest.raises(Cancelled):
        run(spec, Ctx(tmp_path, cancel_after_saves=2))  # GA generation 2 of 3
    interrupted = Ctx(tmp_path, cancel_after_saves=2)
    with pytest.raises(Cancelled):
        run(spec, interrupted)
    resumed = Ctx(tmp_path, checkpoint=interrupted.ckpt)
    b = run(spec, resumed)
    strip = lambda s: {k: v for k, v in json.loads(dumps(s)).items() if k != "timing"}
    assert strip(a.summary) == strip(b.summary)
    assert a.history == b.history
    assert a.evaluations == b.evaluations == spec.evaluations_budget
    assert resumed.progress_log[-1][0] == spec.evaluations_budget


def test_resume_inside_the_random_search_control_is_bit_identical(tmp_path):
    """Killed in the control's second generation (GA: 3 saves, then 1 of the control), the
    resumed job keeps the GA's best row and continues the control from its checkpoint."""
    spec = EnergySpec.parse(CHEAP)
    a = run(spec, Ctx(tmp_path))
    interrupted = Ctx(tmp_path, cancel_after_saves=4)
    with pytest.raises(Cancelled):
        run(spec, interrupted)
    assert set(interrupted.ckpt) == {"ga", "random_search"}
    b = run(spec, Ctx(tmp_path, checkpoint=interrupted.ckpt))
    strip = lambda s: {k: v for k, v in json.loads(dumps(s)).items() if k != "timing"}
    assert strip(a.summary) == strip(b.summary)
    assert a.history == b.history


def test_stop_rule_ends_the_ga_and_its_control_runs_as_many_generations(tmp_path):
    """Counting as every kind counts: generation 0 is the initial population; a target any
    J meets stops the GA after it, and the equal-budget control runs that one generation."""
    spec = EnergySpec.parse(CHEAP | {"stop": {"target": 1e12}})
    ctx = Ctx(tmp_path)
    r = run(spec, ctx)
    done = [d for d, _ in ctx.progress_log]
    assert done == sorted(done) and done[-1] == spec.evaluations_budget  # the bar never runs backwards
    s = r.summary["search"]
    assert (s["stop_reason"], s["generations_run"], s["evaluations"]) == ("target", 1, 4)
    assert [h["generation"] for h in r.history] == [0] and "random_search_best" in r.history[0]
    full = run(EnergySpec.parse(CHEAP), Ctx(tmp_path))
    assert full.summary["search"]["generations_run"] == 3 and full.summary["search"]["stop_reason"] == "generations"
    assert [h["evaluations"] for h in full.history] == [4, 8, 12]


def test_stop_rules_are_strict():
    assert _field_errors({"stop": {"plateau_generations": 0}})[0][0] == "stop.plateau_generations"
    assert _field_errors({"stop": {"target": "1"}})[0][0] == "stop.target"


def test_result_carries_the_stages_and_the_physics_check(tmp_path):
    spec = EnergySpec.parse(CHEAP | {"search": {"optimizer": "none", "workers": 1},
                                              "evidence": {"controls": True, "robustness": True,
                                                           "random_search": False}})
    r = run(spec, Ctx(tmp_path))
    s = json.loads(dumps(r.summary))
    assert s["gait"]["period_s"] == 0.46 and s["links_m"] == [0.06, 0.33, 0.33]
    assert set(s["cot"]) == {"nlp_first", "nlp", "qp", "final", "physics"}
    assert s["eps"]["qp"]["norm"] < s["eps"]["nlp"]["norm"]
    assert s["physics"]["periods_completed"] == 1
    names = {c["name"] for c in s["controls"]}
    assert {"paper_table1", "srb_only", "high_step", "rod_inertia", "no_residual_iteration"} <= names
    for c in s["controls"]:
        assert set(c) == {"name", "label", "evaluations", "metrics", "target_met", "note"}
    rob = s["robustness"]
    assert rob["total"] == len(rob["cases"]) == 6 and 0 <= rob["met"] <= 6
    assert r.evaluations == spec.evaluations_budget
    assert "qpos" in r.traces["physics"] and "f_qp" in r.traces["forces"]
    # Presentation through the contract: headline, tables, plotly views, figures.
    from app.jobs.registry import get_kind

    kind = get_kind("energy")
    rows = kind.headline(s)
    assert any(row["label"].startswith("CoT final") for row in rows)
    assert {t["title"] for t in kind.summary_tables(s)} >= {"Gait and design", "Cost of transport per stage"}
    views = kind.views(s, r.traces)
    assert [v["id"] for v in views] == ["forces", "body", "residuals", "gait"] and json.loads(json.dumps(views))
    files = kind.figures(r, tmp_path / "plots")
    assert {f.stem for f in files} == set(kind.figure_descriptions)


@pytest.mark.parametrize("bad, field", [
    ({"gait": {"family": "free", "duty": [0.5, 0.5, 1.0, 0.5]}}, "gait.duty"),
    ({"design": {"links_m": [0.06, 0.22, 0.22]}}, "design.links_m"),
    ({"task": {"speed_m_s": -0.5}}, "task.speed_m_s"),
])
def test_cli_exits_2_naming_the_field_and_writes_nothing(tmp_path, bad, field):
    import os
    import subprocess
    import sys

    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"kind": "energy"} | bad))
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "app", "run", str(spec), "--out", str(out)], capture_output=True,
                       text=True, env=os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[3])})
    assert p.returncode == 2, p.stderr
    assert field in p.stderr
    assert not out.exists()


def test_numbers_do_not_depend_on_the_worker_count(tmp_path):
    base = {"kind": "energy", "search": {"population": 4, "generations": 1}, "model": {"knots": 48},
            "physics": {"periods": 1}, "evidence": {"controls": False, "robustness": False, "random_search": False}}
    one = run(EnergySpec.parse(base | {"search": base["search"] | {"workers": 1}}), Ctx(tmp_path))
    two = run(EnergySpec.parse(base | {"search": base["search"] | {"workers": 2}}), Ctx(tmp_path))
    assert one.history == two.history and one.summary["J"] == two.summary["J"]


def test_free_family_space_round_trips_table1_and_decodes_timing():
    from app.jobs.energy.problem import decode, encode_nominal, space

    spec = EnergySpec.parse({"kind": "energy", "gait": {"family": "free"}})
    sp = space(spec)
    assert sp.names[:8] == ("T_s", "phase_HR", "phase_FL", "phase_HL", "beta_FR", "beta_HR", "beta_FL", "beta_HL")
    assert len(sp.lower) == 11 and (sp.lower < sp.upper).all()
    gait, links = decode(sp, encode_nominal(sp, spec))
    assert gait.period == 0.46 and gait.touchdown == pytest.approx((0.0, 0.23, 0.23, 0.0))
    assert gait.duty == (0.5,) * 4 and links == (0.06, 0.33, 0.33)
    x = encode_nominal(sp, spec)
    x[1:4], x[4:8] = (0.5, 0.75, 0.25), (0.7, 0.7, 0.7, 0.7)  # a walk
    gait, _ = decode(sp, x)
    assert gait.touchdown == pytest.approx((0.0, 0.23, 0.345, 0.115)) and gait.duty == (0.7,) * 4
