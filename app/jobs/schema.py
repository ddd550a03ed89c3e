"""The job spec's JSON schema as an API document publishes it: a discriminated union on
``kind`` over every registered kind's Spec, each section named after its kind
(``RecoverySearch``, ``MultigaitSearch`` ...) so that no two schemas share a name or a
title (a client generator makes one class per title and drops the spec whose section
name collides), and a small example per kind (its smoke spec)."""

from __future__ import annotations

import re
from typing import Annotated, Any, Union

from pydantic import Field, TypeAdapter
from pydantic.json_schema import GenerateJsonSchema

from app.jobs.registry import KINDS

_SIMPLE_REF = re.compile(r"^(?P<module>[\w.]+)\.(?P<name>\w+):(?P<id>\d+)$")


def kind_prefix(kind_name: str) -> str:
    """"recovery" -> "Recovery": the name every schema of that kind's spec starts with."""
    return "".join(p[:1].upper() + p[1:] for p in re.split(r"[_\W]+", kind_name) if p)


def _owners() -> dict[str, str]:
    """{module prefix: schema name prefix}: a kind's package (the folder of its Spec's
    module, or that module itself for a one-module kind) -> its kind's prefix."""
    out = {}
    for name, kind in KINDS.items():
        module = kind.Spec.__module__
        package = module.rpartition(".")[0] if module.startswith("app.jobs.") else module
        out[package] = kind_prefix(name)
    return out


class KindSchemaNames(GenerateJsonSchema):
    """Pydantic's schema generator, with every model defined in a kind's package named
    after the kind (Search -> RecoverySearch) unless its name already says so; models
    shared by kinds (defined outside their packages) keep their own names."""

    owners: dict[str, str] = {}

    def get_defs_ref(self, core_mode_ref):
        core_ref, mode = core_mode_ref
        m = _SIMPLE_REF.match(core_ref)
        if m:
            prefix = next((p for pkg, p in self.owners.items()
                           if m["module"] == pkg or m["module"].startswith(pkg + ".")), None)
            if prefix and not m["name"].startswith(prefix):
                core_ref = f"{m['module']}.{prefix}{m['name']}:{m['id']}"
        return super().get_defs_ref((core_ref, mode))


def spec_union():
    """The body of POST /api/jobs: a discriminated union on `kind` over every registered kind."""
    models = tuple(k.Spec for k in KINDS.values())
    if len(models) == 1:
        return models[0]
    return Annotated[Union[models], Field(discriminator="kind")]  # noqa: UP007


def examples() -> dict[str, dict[str, Any]]:
    """{kind: a spec that runs in seconds} for every kind that has a smoke spec, else its
    shortest spec ({"kind": name})."""
    out = {}
    for name, kind in KINDS.items():
        smoke = getattr(kind, "smoke_spec", None)
        out[name] = (smoke() if callable(smoke) else None) or {"kind": name}
    return out


def spec_json_schema(ref_template: str = "#/components/schemas/{model}") -> tuple[dict, dict]:
    """(the union's schema, the named schemas it refers to). Each schema's title is its
    name; each kind's Spec carries its example; a body must name its `kind`."""
    gen = type("Names", (KindSchemaNames,), {"owners": _owners()})
    schema = TypeAdapter(spec_union()).json_schema(ref_template=ref_template, schema_generator=gen)
    defs = schema.pop("$defs", {})
    for name, d in defs.items():
        d["title"] = name
    ex = examples()
    for kind_name, ref in (schema.get("discriminator") or {}).get("mapping", {}).items():
        branch = defs[ref.rsplit("/", 1)[1]]
        branch["examples"] = [ex[kind_name]]
    for branch in [defs[r.rsplit("/", 1)[1]] for r in (schema.get("discriminator") or {}).get("mapping", {}).values()] \
            or [schema]:
        if "kind" in branch.get("properties", {}):
            branch["required"] = ["kind", *[f for f in branch.get("required", []) if f != "kind"]]
    schema["title"] = "JobSpec"
    schema["description"] = ("A job: one kind's spec, chosen by `kind` (" + ", ".join(KINDS) + "). Every field has "
                             "its paper's default; unknown fields are rejected.")
    schema["examples"] = list(ex.values())
    return schema, defs
