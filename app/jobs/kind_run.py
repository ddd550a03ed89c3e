"""What runs a job: the part of the kind contract the worker, the API's queueing checks and
the studies use (``RunsJob``). app/jobs/base.py composes it with the presentation
(app/jobs/kind_present.py) and the reproduction (app/jobs/kind_reproduce.py) into ``Kind``."""

from __future__ import annotations

import abc
from typing import Any, ClassVar

from app.jobs.job_result import JobResult
from app.jobs.run_context import RunContext
from app.jobs.spec_base import SpecBase


class RunsJob(abc.ABC):
    """What runs a job of the kind: ``run`` (required), the robots it runs on, the checks
    made before a job is queued, the studies over its spec, and ``play`` for the
    adaptation.

    Invariants:
        - Same spec and seed, same numbers: ``run`` draws every random number from the
          spec's seed and gives bit-identical results (timings under ``summary["timing"]``
          aside), also when it resumes from its last checkpoint.
        - ``run`` performs exactly ``spec.evaluations_budget`` evaluations, and checks
          ``ctx.is_cancelled()`` between units of work (a generation, or a run).
        - Everything here is science: no database session, Celery object or HTTP request
          reaches it; the outside world is the ``RunContext``.

    Ownership:
        - The kind owns its spec's meaning, its numbers and its checkpoints' content (JSON,
          read back only by the same kind); the caller (app/service/runner.py, `gaitmend
          run`, the experiments) owns the context: where progress and checkpoints go,
          the cancel flag, the artifact folder and the uploaded robots.
        - The result (``JobResult``) belongs to the caller once returned; the bundle
          writer stores it as it is.

    Raises:
        - ``Cancelled`` from ``run`` when the cancel flag is seen (nothing is returned).
        - ``SpecError`` for a spec that must not run (``Spec.parse``, ``default_spec``,
          ``RunContext.load_robot`` for an unknown robot id), naming each field.
        - ``NotImplementedError`` from ``play`` for a kind with no gait to play.
        - ``user_robot_error`` and ``infeasible_reason`` never raise: they return the
          reason as text, or None.
    """

    @abc.abstractmethod
    def run(self, spec: Any, ctx: RunContext) -> JobResult:
        """Run the job: report progress, checkpoint, check cancel between units of work
        (raise ``Cancelled``); same spec and seed, same numbers, also after a resume."""

    def smoke_spec(self) -> dict[str, Any] | None:
        """A spec (JSON) that runs in seconds and checkpoints at least once: the contract
        tests (tests/jobs/test_contract.py) run every kind with it."""
        return None

    def robot_info(self, robot: str) -> dict[str, Any]:
        """Details of one of ``robots`` for /api/robots and the form (legs, modules,
        parameters ...); JSON."""
        return {}

    def default_spec(self) -> SpecBase:
        """The spec with every default (``{"kind": name}`` parsed)."""
        return self.Spec.parse({"kind": self.name})

    user_robots: ClassVar[bool] = False
    """Whether the kind runs on an uploaded robot (its spec's ``robot`` is the robot's id;
    the run reads it with ``RunContext.load_robot``): /api/robots lists the kind for them."""

    def user_robot_error(self, spec: SpecBase, legs: dict[str, Any]) -> str | None:
        """Why ``spec`` cannot run on the uploaded robot of leg map ``legs`` (JSON): a leg or
        joint it names that the map lacks, a robot that cannot stand ...; None when it can.
        The API asks before it queues the job."""
        return None

    def play(self, spec: Any, gaits: Any, joints: list[str], perturbation: Any = None,
             stored: Any = None) -> dict[str, list[Any]]:
        """Plays gaits of the kind's own controller on the robot of ``spec`` (its damage, its
        trial length and timestep) under ``perturbation`` (app/sim/perturb.py ``Perturbation``,
        None: the nominal model), as a lab would run them; ``stored``: the uploaded robot
        (app/robots/legmap.py ``Robot``) when ``spec.robot`` is one. ``gaits`` (P, n) are parameters
        over the servos named ``joints`` (the order of the map that holds them; a servo the
        damaged robot no longer has is dropped), or, for a kind whose gaits are not per
        servo, over its own parameters of that name (recovery: ``bounds.names``). Returns
        per gait the measured ``forward_m``,
        ``lateral_m``, ``yaw_deg``, ``fell`` and ``duration_s`` (lists). The adaptation's
        simulated reality (app/adapt/reality.py) calls it; a kind without a gait to play
        raises NotImplementedError (the default)."""
        raise NotImplementedError(f"kind {self.name!r} has no gait to play")

    # -- studies --------------------------------------------------------------------------
    def named_values(self) -> dict[str, dict[str, list[Any]]]:
        """Named value sets a study grid may use instead of a list, by dotted spec path:
        {"damage.lost_legs": {"all_feasible_1_and_2": [[1], [2], ...]}}."""
        return {}

    def infeasible_reason(self, data: dict[str, Any]) -> str | None:
        """Why a spec (a dict, before validation) describes a robot that cannot run at all
        (a study lists such points instead of queueing them), else None. Malformed input is
        the Spec's to reject: return None for it."""
        return None

    def builtin_studies(self) -> dict[str, dict[str, Any]]:
        """The kind's built-in studies: {name: study spec (JSON)}, the paper's table first.
        A name is unique over all kinds; each study's base is a job of this kind.
        app/studies/catalog.py gathers them over the registry (`gaitmend study run NAME`,
        `gaitmend reproduce <kind>-study`, /api/studies/builtin). Default: none."""
        return {}
