"""The OpenAPI document is one a client generator can use: every schema has its own name
(no two share a title; sections named after their kind, RecoverySearch, MultigaitSearch
...), the job spec is a discriminated union on `kind` over named schemas, each kind's spec
carries an example that the API accepts, and no union is anonymous. openapi-python-client,
installed from PyPI, generates a client from the served document that submits a job and
reads it back."""

from __future__ import annotations

import json
import re
import subprocess
import textwrap

import httpx
import pytest

from app.jobs.registry import KINDS, parse_spec
from app.jobs.schema import kind_prefix

PRIMITIVE = {"string", "number", "integer", "boolean", "null"}


def name_problems(doc: dict) -> list[str]:
    """Schema names a generator would trip over: module-mangled or non-identifier names, a
    title that is not the name, a title two schemas share."""
    out, seen = [], {}
    for name, schema in doc["components"]["schemas"].items():
        if not re.fullmatch(r"[A-Z][A-Za-z0-9]*", name):
            out.append(f"{name}: not a plain class name")
        title = schema.get("title", name)
        if title != name:
            out.append(f"{name}: titled {title!r}")
        if title in seen:
            out.append(f"{name}: title {title!r} also used by {seen[title]}")
        seen[title] = name
    return out


def anonymous_unions(node, path: str = "") -> list[str]:
    """Every oneOf/anyOf member must be a $ref or a schema with no members of its own (a
    primitive, a list or a map): an inline object or an empty schema becomes "any"."""
    out = []
    if isinstance(node, dict):
        for key in ("oneOf", "anyOf"):
            for i, m in enumerate(node.get(key, [])):
                if "$ref" in m:
                    continue
                if not m or "properties" in m or ("type" not in m and "const" not in m and "enum" not in m):
                    out.append(f"{path}/{key}/{i}")
        for k, v in node.items():
            out += anonymous_unions(v, f"{path}/{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += anonymous_unions(v, f"{path}/{i}")
    return out


@pytest.fixture(scope="module")
def doc(served):
    return httpx.get(f"{served[0]}/openapi.json", timeout=60).json()


def test_schema_names_are_unique_and_union_named(doc):
    assert name_problems(doc) == []
    assert anonymous_unions(doc) == []
    comps = doc["components"]["schemas"]
    spec = comps["JobSpec"]
    assert spec["discriminator"]["propertyName"] == "kind"
    assert all(set(m) == {"$ref"} for m in spec["oneOf"])
    mapping = spec["discriminator"]["mapping"]
    assert mapping == {k: f"#/components/schemas/{kind_prefix(k)}Spec" for k in KINDS}
    assert {"RecoverySearch", "MultigaitSearch", "RecoveryDamage", "MultigaitDamage", "RecoveryControls",
            "MultigaitControls", "RecoveryRobustness", "MultigaitRobustness"} <= set(comps)
    for k in KINDS:
        branch = comps[f"{kind_prefix(k)}Spec"]
        assert branch["required"][0] == "kind" and branch["examples"]
        assert parse_spec(branch["examples"][0]).kind == k  # the example is a valid spec of its kind
    body = doc["paths"]["/api/jobs"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert body == {"$ref": "#/components/schemas/JobSpec"}


def test_the_checks_can_fail():
    """Planted defects: a title two schemas share, a mangled name, inline and empty union members."""
    bad = {"components": {"schemas": {
        "app__jobs__x__Search": {"title": "Search"}, "Search": {"title": "Search"},
        "U": {"oneOf": [{"type": "object", "properties": {"a": {}}}, {}, {"$ref": "#/x"}, {"type": "null"}]}}}}
    problems = name_problems(bad)
    assert any("not a plain class name" in p for p in problems) and any("also used by" in p for p in problems)
    assert anonymous_unions(bad) == ["/components/schemas/U/oneOf/0", "/components/schemas/U/oneOf/1"]


ROUND_TRIP = textwrap.dedent('''
    import importlib, json, sys, time
    sys.path.insert(0, sys.argv[1])
    base, post_mod, get_mod, spec = sys.argv[2], sys.argv[3], sys.argv[4], json.loads(sys.argv[5])
    from gaitmend_api import Client
    from gaitmend_api.models import RecoverySpec, JobOut
    submit, get_job = importlib.import_module(post_mod), importlib.import_module(get_mod)
    with Client(base_url=base, raise_on_unexpected_status=True) as c:
        body = RecoverySpec.from_dict(spec)
        job = submit.sync(client=c, body=body)
        assert isinstance(job, JobOut), job
        for _ in range(600):
            job = get_job.sync(job_id=job.id, client=c)
            if job.status.value in ("succeeded", "failed", "cancelled"):
                break
            time.sleep(0.5)
        print(json.dumps({"id": job.id, "status": job.status.value, "kind": job.kind,
                          "sent": body.to_dict(), "headline": [h.label for h in job.headline],
                          "fitness": job.summary.to_dict()["best"]["fitness"]}))
''')


def _module(doc: dict, path: str, method: str) -> str:
    op = doc["paths"][path][method]
    return f"gaitmend_api.api.{op['tags'][0]}.{re.sub(r'[^a-z0-9]+', '_', op['operationId'].lower())}"


def test_a_generated_client_round_trips_a_job(doc, generator_venv, client, finished, tmp_path):
    venv = generator_venv.path()
    (tmp_path / "openapi.json").write_text(json.dumps(doc))
    env = {"PATH": f"{venv}/bin:/usr/bin:/bin", "HOME": str(tmp_path)}
    gen = subprocess.run([f"{venv}/bin/openapi-python-client", "generate", "--path", "openapi.json",
                          "--output-path", "gaitmend_api", "--meta", "none"], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    text = gen.stdout + gen.stderr
    assert gen.returncode == 0 and "Warning" not in text and "Unable" not in text, text[-4000:]
    spec = KINDS["recovery"].smoke_spec() | {"search": {"population": 4, "generations": 1, "seed": 11}}
    r = subprocess.run([f"{venv}/bin/python", "-c", ROUND_TRIP, str(tmp_path), client.server,
                        _module(doc, "/api/jobs", "post"), _module(doc, "/api/jobs/{job_id}", "get"),
                        json.dumps(spec)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-4000:]
    got = json.loads(r.stdout.strip().splitlines()[-1])
    assert got["status"] == "succeeded" and got["kind"] == "recovery" and got["sent"]["kind"] == "recovery"
    ours = client.job(got["id"])  # what the generated code read is what the server holds
    assert ours.spec["search"]["seed"] == 11
    assert got["headline"] == list(ours.headline["label"]) and got["fitness"] == ours.summary["best"]["fitness"]
