"""The base of every kind's spec and the error a spec that must not run raises: ``SpecError``
(the fields at fault, each with its message), ``StrictModel`` (a strict section: unknown
fields rejected, no type coercion, finite numbers only) and ``SpecBase`` (what every kind's
``Spec`` declares besides its own sections). app/jobs/base.py re-exports every name."""

from __future__ import annotations

import abc
import json
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, ValidationError


class SpecError(ValueError):
    """A spec that must not run. ``errors`` is a list of {"field": dotted path, "message"}."""

    def __init__(self, errors: list[dict[str, str]]):
        self.errors = errors
        super().__init__("; ".join(f"{e['field']}: {e['message']}" for e in errors))

    @classmethod
    def from_validation(cls, exc: ValidationError, model: type[BaseModel] | None = None) -> SpecError:
        """The errors of a failed validation of ``model`` (default: the StrictModel the error
        is titled after, when one has that name); a range error states the field's whole
        allowed range (app/jobs/ranges.py)."""
        from app.jobs.ranges import explain_error

        model = model if model is not None else _model_named(exc.title)
        out = []
        for e in exc.errors():
            loc = ".".join(str(p) for p in e["loc"] if p not in ("function-after",)) or "spec"
            msg = e["msg"]
            if e["type"] == "extra_forbidden":
                msg = "unknown field"
            if msg.startswith("Value error, "):
                msg = msg[len("Value error, "):]
            out.append({"field": loc, "message": explain_error(model, e, msg)})
        return cls(out)


def _model_named(title: str) -> type[BaseModel] | None:
    """The one StrictModel class named ``title`` (a ValidationError names the model it
    validated, not its class), or None when no class or several have that name."""
    found, stack = [], list(StrictModel.__subclasses__())
    while stack:
        c = stack.pop()
        stack.extend(c.__subclasses__())
        if c.__name__ == title and c not in found:
            found.append(c)
    return found[0] if len(found) == 1 else None


# Every spec section uses this: unknown fields rejected, no type coercion ("1" is not 1,
# true is not 1, 1.5 is not an int), finite numbers only.
STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class StrictModel(BaseModel):
    """A section of a spec (damage, search, sim ...): strict, as the whole spec."""

    model_config = STRICT


class SpecBase(StrictModel):
    """What every kind's ``Spec`` declares besides its own sections.

    - ``kind``: a ``Literal[name]`` field (the discriminator of the API's spec union);
    - ``robot``: the robot it simulates (one of the kind's ``robots``);
    - ``seed``: an int field or property: every random draw of the job comes from it;
    - ``evaluations_budget``: property, the number of evaluations (simulations, or
      rollouts) the job will run in all phases, as stated in words in ``budget_formula``.

    Specs are parsed from JSON (``parse``): strict pydantic accepts a JSON array for a
    tuple field in JSON mode only, and CLI, API and bundles all hold JSON.
    """

    kind: str
    robot: str
    budget_formula: ClassVar[str] = ""
    budget_field: ClassVar[str] = "spec"  # the field to lower when the budget is over a limit

    @property
    @abc.abstractmethod
    def evaluations_budget(self) -> int:
        """Evaluations the job will run in all its phases (``budget_formula`` in words)."""

    @classmethod
    def parse(cls, data: Any):
        """Validate ``data`` (a dict as decoded from JSON); raises SpecError naming fields."""
        try:
            text = json.dumps(data, allow_nan=True)
        except (TypeError, ValueError) as e:
            raise SpecError([{"field": "spec", "message": f"not JSON data: {e}"}]) from None
        try:
            return cls.model_validate_json(text)
        except ValidationError as e:
            raise SpecError.from_validation(e, cls) from None

    @classmethod
    def __pydantic_init_subclass__(cls, **kw: Any) -> None:
        super().__pydantic_init_subclass__(**kw)
        if "kind" in cls.__dict__.get("__annotations__", {}) and not cls.budget_formula:
            raise TypeError(f"{cls.__name__}: a spec states its budget_formula in words")

