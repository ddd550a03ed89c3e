"""The import direction of docs/architecture.md, checked on the source for every package
of app/ and workers/: core at the bottom, then robots, optimisers and shared simulation,
the jobs (the contract and the kinds), the adaptation, the store, studies, results, the service, the API,
and the CLI and workers on top. Science never imports a web, database or queue library;
kinds are reached only through app/jobs; no module imports itself back through others; a
module outside a kind's package that only one kind uses belongs in that kind."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# rank: a package may import packages of lower rank, and itself (jobs and jobs.<kind> are
# peers: the registry imports the kinds, the kinds import the contract)
# (client, the Python client: reads bundles and talks HTTP, never the store or the service;
# the CLI's client commands use it)
RANK = {"core": 0, "app": 0, "robots": 1, "optim": 2, "sim": 2, "jobs": 3, "jobs.<kind>": 3, "adapt": 4, "store": 5,
        "results": 6, "client": 7, "studies": 8, "service": 9, "api": 10, "workers": 11, "cli": 12}
LEAVES = {"core", "app"}  # import nothing of the ranked packages but themselves
SCIENCE = ("robots", "optim", "sim", "jobs", "jobs.<kind>", "adapt")
SERVICE_LIBS = ("fastapi", "sqlalchemy", "celery", "starlette", "uvicorn", "alembic", "redis", "kombu")
# Shared by declaration, even where one kind is today's only user: the robot-model layer
# (every kind asks it for its robot, and uploaded robots will be entries of the same
# form), the optimisers (one ask/tell interface any kind may pick from) and the
# perturbation of a compiled MuJoCo world (any kind's robustness re-runs and robust search).
DECLARED_SHARED = ("app.robots", "app.optim", "app.sim.perturb")


def _group(mod: str) -> str | None:
    parts = mod.split(".")
    if parts[0] == "workers":
        return "workers"
    if parts[0] != "app":
        return None
    if len(parts) == 1:
        return "app"
    if parts[1] == "__main__":
        return "cli"
    if parts[1] == "jobs" and len(parts) > 2 and (ROOT / "app" / "jobs" / parts[2]).is_dir():
        return "jobs.<kind>"  # a kind is a package under app/jobs; modules beside them are shared
    return parts[1]


def _modules() -> dict[str, tuple[Path, set[str]]]:
    files = {".".join(f.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): f
             for f in sorted([*(ROOT / "app").rglob("*.py"), *(ROOT / "workers").rglob("*.py")])}
    out = {}
    for mod, f in files.items():
        imports = set()
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                subs = {f"{node.module}.{a.name}" for a in node.names}
                # `from package import module` needs the module; `from module import name` the module
                imports.update(subs & files.keys() or {node.module} | subs)
            elif isinstance(node, ast.Import):
                imports.update(a.name for a in node.names)
        out[mod] = (f, imports)
    return out


MODULES = _modules()


def _edges(mod: str) -> set[str]:
    return {i for i in MODULES[mod][1] if i in MODULES and i != mod}


def test_every_package_is_ranked():
    unranked = sorted({_group(m) for m in MODULES} - RANK.keys())
    assert not unranked, f"packages with no rank in the layer order: {unranked}"


@pytest.mark.parametrize("mod", sorted(MODULES))
def test_imports_point_down(mod):
    src = _group(mod)
    for target in _edges(mod):
        dst = _group(target)
        if dst == src:
            continue
        assert src not in LEAVES, f"{mod} is a leaf module and imports {target}"
        assert RANK[dst] < RANK[src] or {src, dst} == {"jobs", "jobs.<kind>"}, \
            f"{mod} ({src}) imports {target} ({dst}): against the layer order"


def _kind_of(mod: str) -> str | None:
    parts = mod.split(".")
    return parts[2] if _group(mod) == "jobs.<kind>" else None


def test_no_kind_imports_another_kind():
    for mod in MODULES:
        for target in _edges(mod):
            if _kind_of(mod) and _kind_of(target):
                assert _kind_of(mod) == _kind_of(target), f"{mod} imports another kind's {target}"


def _single_kind_modules() -> list[tuple[str, str]]:
    """Modules outside the kinds' packages whose only importer (directly, by app/ or
    workers/ code outside their own package) is one kind."""
    users: dict[str, set[str]] = {}
    for mod in MODULES:
        for target in _edges(mod):
            if target.rsplit(".", 1)[0] == mod.rsplit(".", 1)[0] and not _kind_of(mod):
                continue  # a sibling in the same shared package is not a user
            users.setdefault(target, set()).add(_kind_of(mod) or mod)
    out = []
    for mod, who in users.items():
        if _group(mod) in SCIENCE and not _kind_of(mod) and not mod.startswith(DECLARED_SHARED) \
                and len(who) == 1 and next(iter(who)) in {_kind_of(m) for m in MODULES}:
            out.append((mod, next(iter(who))))
    return sorted(out)


def test_a_shared_module_has_two_users():
    """A module beside the kinds that only one kind imports is that kind's: it moves into
    app/jobs/<kind>/ (or is declared shared above, with the reason)."""
    lonely = _single_kind_modules()
    assert not lonely, "modules outside a kind used by that kind alone: " + \
        ", ".join(f"{m} (only {k})" for m, k in lonely)


def test_the_single_user_check_can_fail(tmp_path, monkeypatch):
    """The check above is not vacuous: a module planted in app/sim that one kind imports is found."""
    planted = "app.sim.only_recovery"
    monkeypatch.setitem(MODULES, planted, (tmp_path / "only_recovery.py", set()))
    f, imports = MODULES["app.jobs.recovery.run"]
    monkeypatch.setitem(MODULES, "app.jobs.recovery.run", (f, imports | {planted}))
    assert (planted, "recovery") in _single_kind_modules()


@pytest.mark.parametrize("mod", [m for m in MODULES if _group(m) in SCIENCE])
def test_science_never_imports_service_libraries(mod):
    bad = [i for i in MODULES[mod][1] if i.split(".")[0] in SERVICE_LIBS]
    assert not bad, f"{mod} imports {bad}"


def test_no_module_imports_itself_back():
    """Cycles through lazy imports count too: they are cycles a refactor trips over."""
    seen: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        seen[m] = 1
        stack.append(m)
        for n in sorted(_edges(m)):
            if seen.get(n) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(n):] + [n]))
            if n not in seen:
                visit(n)
        stack.pop()
        seen[m] = 2

    for m in sorted(MODULES):
        if m not in seen:
            visit(m)


def test_kinds_are_reached_through_the_registry_only():
    """Outside app/jobs only the registry and the contract are imported, never a kind."""
    for mod, (f, imports) in MODULES.items():
        if _group(mod) in ("jobs", "jobs.<kind>"):
            continue
        kinds = sorted(i for i in imports if _group(i) == "jobs.<kind>")
        assert not kinds, f"{f.relative_to(ROOT)} imports a kind directly: {kinds}"


def test_builtin_studies_are_named_only_in_their_kinds_package():
    """A built-in study belongs to its kind (app/jobs/<kind>/studies/): outside the kinds'
    packages and the registry, app/ and web/ reach them only through app/studies/catalog.py
    and /api/studies/builtin, never by name."""
    from app.studies.catalog import builtin_studies

    names = list(builtin_studies())
    assert names
    kinds = {p for p in (ROOT / "app" / "jobs").iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    hits = []
    for f in sorted([*(ROOT / "app").rglob("*"), *(ROOT / "web").rglob("*")]):
        if not f.is_file() or "__pycache__" in f.parts or f == ROOT / "app" / "jobs" / "registry.py" \
                or any(k in f.parents for k in kinds):
            continue
        text = f.read_text(errors="replace")
        hits += [f"{f.relative_to(ROOT)}: {n}" for n in names if n in text]
    assert not hits, "built-in study names outside their kind's package:\n" + "\n".join(hits)


# -- a kind's runtime and its reproductions (docs/architecture.md, "Where a change goes") ----------

REPRODUCE = "reproduce"  # app/jobs/<kind>/reproduce/: a kind's reproductions, benches, peers, doc generators
MAX_REPRODUCTION_SHARE = 0.10  # of a kind's runtime lines (issue 42)


def _kinds() -> list[str]:
    return sorted({k for m in MODULES if (k := _kind_of(m)) and f"app.jobs.{k}" in MODULES})


def _is_reproduction(mod: str) -> bool:
    parts = mod.split(".")
    return _kind_of(mod) is not None and len(parts) > 3 and parts[3] == REPRODUCE


def _deferred(kind: str) -> dict[str, str]:
    """The kind's ``Deferred(module, attr)`` members by name: the only way the contract
    reaches a module the kind package does not import (so the AST walk cannot see it)."""
    f = ROOT / "app" / "jobs" / kind / "__init__.py"
    out = {}
    for node in ast.walk(ast.parse(f.read_text())):
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) \
                and getattr(node.value.func, "id", None) == "Deferred" and node.value.args:
            out[node.targets[0].id] = f"app.jobs.{kind}{node.value.args[0].value}"
    return out


def _runtime(kind: str) -> set[str]:
    """The modules a job of ``kind`` can load: its package and the Deferred members other
    than the research hooks (experiments, bench), with everything they import."""
    roots = [f"app.jobs.{kind}"] + [m for name, m in _deferred(kind).items() if name not in ("experiments", "bench")]
    seen: set[str] = set()
    stack = list(roots)
    while stack:
        m = stack.pop()
        if m in seen or m not in MODULES:
            continue
        seen.add(m)
        # a module needs its packages' __init__ too
        stack += [p for p in (".".join(m.split(".")[:i]) for i in range(3, len(m.split(".")))) if p in MODULES]
        stack += sorted(_edges(m))
    return seen


def _lines(mods) -> int:
    return sum(len(MODULES[m][0].read_text().splitlines()) for m in mods)


def _split(kind: str) -> tuple[set[str], set[str], set[str]]:
    """(runtime, reproduction, neither) modules of the kind's package."""
    own = {m for m in MODULES if _kind_of(m) == kind}
    runtime = {m for m in _runtime(kind) if _kind_of(m) == kind}
    repro = {m for m in own if _is_reproduction(m)}
    return runtime, repro, own - runtime - repro


@pytest.mark.parametrize("kind", _kinds())
def test_runtime_never_imports_the_reproductions(kind):
    """No module a job loads reaches its kind's reproduce/ package; only the research hooks
    (``experiments``, ``bench``) name it."""
    runtime, _, _ = _split(kind)
    bad = sorted(m for m in runtime if _is_reproduction(m))
    assert not bad, f"the {kind} job's runtime loads reproduction modules: {bad}"
    for name, target in _deferred(kind).items():
        if name not in ("experiments", "bench"):
            assert not _is_reproduction(target), f"{kind}.{name} = Deferred({target}): a runtime member in {REPRODUCE}/"


@pytest.mark.parametrize("kind", _kinds())
def test_code_a_job_never_loads_is_a_reproduction(kind):
    """Every module of a kind is either loaded by its jobs or kept in its reproduce/ package,
    and reproduction code left among the runtime modules stays under the issue's 10 %."""
    runtime, repro, neither = _split(kind)
    share = _lines(neither) / max(_lines(runtime), 1)
    assert share <= MAX_REPRODUCTION_SHARE and not neither, (
        f"{kind}: modules no job loads, outside {REPRODUCE}/ ({share:.0%} of the runtime's "
        f"{_lines(runtime)} lines): {sorted(neither)}")


def test_the_reproduction_checks_can_fail(monkeypatch):
    """Not vacuous: a runtime module that imports its kind's reproduce/ and a module no job
    loads outside reproduce/ are both found."""
    kind = "recovery"
    repro = sorted(m for m in MODULES if _kind_of(m) == kind and _is_reproduction(m))
    assert repro, "recovery has a reproduce/ package"
    f, imports = MODULES["app.jobs.recovery.run"]
    monkeypatch.setitem(MODULES, "app.jobs.recovery.run", (f, imports | {repro[0]}))
    assert repro[0] in _split(kind)[0]
    monkeypatch.setitem(MODULES, "app.jobs.recovery.run", (f, imports))
    monkeypatch.setitem(MODULES, "app.jobs.recovery.orphan", (MODULES["app.jobs.recovery.run"][0], set()))
    assert "app.jobs.recovery.orphan" in _split(kind)[2]
