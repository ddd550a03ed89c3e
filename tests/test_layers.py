"""The import direction of docs/architecture.md, checked on the source: science packages
import only downward (robots at the bottom) and never a web, database or queue library;
kinds are reached only through app/jobs; no module imports itself back through others."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# rank: a package may import packages of lower or equal rank (same rank: itself only,
# except where listed in PEERS)
RANK = {"robots": 0, "gaits": 1, "sim": 2, "stability": 3, "planning": 3, "dynamics": 3, "optim": 4,
        "jobs": 5, "jobs.<kind>": 5}
LEAVES = {"colors", "settings", "plots", "app"}  # import nothing of the ranked packages
SERVICE_LIBS = ("fastapi", "sqlalchemy", "celery", "starlette", "uvicorn", "alembic", "redis", "kombu")


def _group(mod: str) -> str | None:
    parts = mod.split(".")
    if parts[0] == "workers":
        return "workers"
    if parts[0] != "app":
        return None
    if len(parts) == 1:
        return "app"
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


@pytest.mark.parametrize("mod", [m for m in MODULES if _group(m) in RANK or _group(m) in LEAVES])
def test_imports_point_down(mod):
    src = _group(mod)
    for target in _edges(mod):
        dst = _group(target)
        if dst == src or dst in LEAVES and src not in LEAVES:
            continue
        assert src not in LEAVES, f"{mod} is a leaf module and imports {target}"
        assert dst in RANK and RANK[dst] < RANK[src] or {src, dst} == {"jobs", "jobs.<kind>"}, \
            f"{mod} ({src}) imports {target} ({dst}): against the layer order"


@pytest.mark.parametrize("mod", [m for m in MODULES if _group(m) in RANK and _group(m) not in ("jobs", "jobs.<kind>")])
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
