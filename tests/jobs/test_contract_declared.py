"""The kind contract is declared, not looked up by name: every member a kind may set is
declared on ``Kind`` (app/jobs/base.py) with its default and a docstring, and a kind that
sets anything else (a misspelt optional member, which a lookup by name would ignore in
silence), or gives a method's place something that cannot be called like it, is refused
when it is registered."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

from app.jobs import base, registry
from app.jobs.base import (Kind, PackageKind, PresentsResult, ReproducesPaper, RunsJob, check_kind,
                           contract_members)

RecoveryKind = type(registry.KINDS["recovery"])


@pytest.fixture(autouse=True)
def registry_unchanged():
    before = dict(registry.KINDS)
    yield
    assert registry.KINDS == before


def test_a_misspelt_member_is_refused_at_registration():
    class Misspelt(RecoveryKind):
        name = "misspelt"

        def histroy_axis(self, spec):  # history_axis, misspelt
            return None

    with pytest.raises(TypeError, match=r"Misspelt\.histroy_axis is not a member.*did you mean 'history_axis'"):
        registry.register(Misspelt())
    assert "misspelt" not in registry.KINDS


def test_a_misspelt_attribute_or_instance_member_is_refused():
    class Attr(RecoveryKind):
        name = "attr"
        from_open = ["damage"]  # form_open

    with pytest.raises(TypeError, match="from_open"):
        registry.register(Attr())
    kind = RecoveryKind()
    kind.study_oder = ()  # study_order
    with pytest.raises(TypeError, match="study_oder"):
        registry.register(kind)


def test_a_method_given_something_that_cannot_be_called_like_it_is_refused():
    from app.jobs.recovery import present

    class Bare(RecoveryKind):  # a module function without staticmethod would get the kind as summary
        name = "bare"
        headline = present.headline

    with pytest.raises(TypeError, match=r"Bare\.headline.*cannot be called as Kind\.headline"):
        check_kind(Bare())

    class Value(RecoveryKind):
        name = "value"
        experiments = []

    with pytest.raises(TypeError, match=r"Value\.experiments must be callable"):
        check_kind(Value())


def test_a_deferred_member_in_a_module_that_does_not_exist_is_refused():
    class WrongModule(RecoveryKind):
        name = "wrong_module"
        run = base.Deferred("app.jobs.recovery.rnu", "run")  # .run, misspelt: refused before anything runs

    with pytest.raises(TypeError, match=r"WrongModule\.run: no module 'app\.jobs\.recovery\.rnu'"):
        registry.register(WrongModule())
    assert "wrong_module" not in registry.KINDS


def test_deferred_members_import_their_module_when_first_used():
    kind = registry.KINDS["recovery"]
    from app.jobs.recovery.reproduce.experiments import EXPERIMENTS
    from app.jobs.recovery.run import run

    assert kind.experiments() is EXPERIMENTS
    assert isinstance(RecoveryKind.__dict__["run"], base.Deferred) and kind.run.__name__ == run.__name__


def test_a_kind_without_a_required_member_is_refused():
    class NoPaper(Kind):
        name, title, Spec, robots = "nopaper", "no paper", RecoveryKind.Spec, {}

        def run(self, spec, ctx):
            raise NotImplementedError

        def headline(self, summary):
            return []

        def summary_tables(self, summary):
            return []

        def figures(self, result, out_dir):
            return []

    with pytest.raises(TypeError, match="paper"):
        registry.register(NoPaper())


def test_registered_kinds_pass_and_supply_their_members():
    for kind in registry.KINDS.values():
        check_kind(kind)
        assert isinstance(kind.experiments(), list) and isinstance(kind.bench(), list)
        assert isinstance(list(kind.form_open), list)


def test_the_members_the_dashboard_reads_are_declared_with_defaults():
    members = contract_members(PackageKind)
    assert {"history_axis", "form_open", "study_order", "views", "study_views"} <= set(members)
    assert Kind.form_open == ()

    class Plain(RecoveryKind):
        history_columns = {"generation": "0 = first", "best": "best so far; m", "mean": "mean"}
        history_axis = Kind.history_axis

    axis = Plain().history_axis({})
    assert axis == {"x": "generation", "x_note": "0 = first", "y": "best so far", "better": None,
                    "series": {"best": "best so far", "mean": "mean"}}


def _attribute_docstrings(declaring: type) -> dict[str, bool]:
    tree = ast.parse(Path(inspect.getsourcefile(declaring)).read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == declaring.__name__)
    out = {}
    for stmt, nxt in zip(cls.body, [*cls.body[1:], None]):
        target = stmt.target if isinstance(stmt, ast.AnnAssign) else (
            stmt.targets[0] if isinstance(stmt, ast.Assign) else None)
        if isinstance(target, ast.Name) and not target.id.startswith("_") and target.id != "REQUIRED":
            out[target.id] = isinstance(nxt, ast.Expr) and isinstance(getattr(nxt, "value", None), ast.Constant)
    return out


def test_every_member_has_a_docstring():
    # Kind is its identity and three parts (running, presenting, reproducing): each
    # declaring class is read in its own module
    for cls in (RunsJob, PresentsResult, ReproducesPaper, Kind, PackageKind):
        attrs = _attribute_docstrings(cls)
        for name in contract_members(cls):
            declared = cls.__dict__.get(name)
            if name in attrs:
                assert attrs[name], f"{cls.__name__}.{name} has no docstring"
            elif declared is not None and inspect.isfunction(declared):
                assert inspect.getdoc(declared), f"{cls.__name__}.{name} has no docstring"
