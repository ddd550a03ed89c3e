"""Issue 44's arm "the recovery kind's DE searched on the believed damage" in the adaptation's
evaluation (app/adapt/reproduce/evaluation.py): a recovery job (``DE_SPEC``) in simulation on
the damage the lab believes (``believed_damage``: the true one with its last joint fault left
out), its answer played once on the reality through the recovery kind's ``Kind.play``
(app/jobs/recovery/play.py). It runs after a reality's other arms (``de_pass``), is kept when
they are re-run, and ``--de-only`` runs it on a file's realities without the maps."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

from app.adapt.reality import Measured, Reality
from app.adapt.recovered import recovered
from app.jobs.base import MemoryContext, SpecError
from app.jobs.ledger import write_json_atomic
from app.jobs.registry import get_kind, parse_spec

DE_ARM = "de_believed"
# the recovery job a lab that believed a damage would submit (the fast preset: it stops once the answer meets the
# recovery target, confirmed at half the step); the controls, the named cases and the held-out models are off: they
# judge an answer, they do not change it
DE_SPEC = {"kind": "recovery", "preset": "fast", "controls": {"random_search": False},
           "robustness": {"cases": [], "held_out": 0}}
# the tests' size (``--quick``): the recovery kind's smallest search over 1 s walks
DE_QUICK = DE_SPEC | {"search": {"population": 6, "generations": 2}, "sim": {"duration_s": 1.0}}
DE_BELIEVED = {"run": True, "spec": DE_SPEC, "words": (
    "the recovery kind's DE (fast preset) searched in simulation on the damage the lab believes (the true one with "
    "its last joint fault left out), its answer tried once on the reality over the recovery walk (10 s)")}
JOINT_FAULTS = ("locked_joints", "weak_joints", "passive_joints", "stiff_joints", "shortened_legs")


def believed_damage(damage: dict) -> dict:
    """What a lab believes of ``damage``: every lost leg (a missing leg is seen) and every joint
    fault but the last one listed (in ``JOINT_FAULTS``' order: locked, weak, passive, stiff
    joints, shortened legs); a damage of lost legs alone is believed as it is."""
    out = {k: list(v) for k, v in damage.items() if v}
    for key in reversed(JOINT_FAULTS):
        if out.get(key):
            out[key] = out[key][:-1]
            if not out[key]:
                del out[key]
            break
    return out


def run_de_believed(drawn: dict, seed: int, profile: Any, quick: bool = False) -> dict:
    """The arm ``DE_ARM`` on one reality: a recovery job (``DE_SPEC``, search seed ``seed``) on
    the believed damage in the nominal world, its answer played once (the recovery kind's
    ``Kind.play``) on the true damage in the reality's world. A damage the recovery kind
    refuses (e.g. an uploaded robot left with three legs) is recorded with the refusal and
    counts as not recovered: the lab gets no gait. ``profile``: the evaluation's robot
    (evaluation.py ``Profile``); ``quick``: ``DE_QUICK``, the tests' size."""
    t0 = time.perf_counter()
    kind = get_kind("recovery")
    true = drawn["reality"]["damage"]
    believed = believed_damage(true)
    fixed = DE_QUICK if quick else DE_SPEC
    base = fixed | {"robot": profile.robot, "search": fixed.get("search", {}) | {"seed": int(seed)}}
    ctx = MemoryContext(robots=profile.robots if profile.stored is not None else None)
    stored = profile.stored
    out = {"trials": 1, "method_stopped": True, "believed_damage": believed}
    try:
        spec = parse_spec(base | {"robot_damage": believed})
        if profile.stored is not None:
            why = kind.user_robot_error(spec, profile.stored.legs.to_json())
            if why:
                raise SpecError([{"field": "robot_damage", "message": why.removeprefix("robot_damage: ")}])
        job = kind.run(spec, ctx).summary
    except SpecError as e:
        return out | {"recovered_at": None, "stop": f"refused: {e}", "final_speed_m_s": 0.0, "final_fell": False,
                      "final_lateral_m": 0.0, "final_yaw_deg": 0.0, "tried": "none (refused)",
                      "seconds": time.perf_counter() - t0}
    names = job["bounds"]["names"]
    x = [job["best"]["params"][n] for n in names]
    reality = Reality.parse(drawn["reality"], profile.robots if profile.stored is not None else None)
    m = kind.play(parse_spec(base | {"robot_damage": true}), [x], names, reality.perturbation.perturbation(),
                  stored)
    got = Measured(m["forward_m"][0], m["lateral_m"][0], m["yaw_deg"][0], m["fell"][0], m["duration_s"][0])
    ok = recovered(got.forward_m, got.fell, got.duration_s, reality.robot, reality.stored)
    stop = (f"one answer (the search stopped on {job['search']['stop_reason']} after "
            f"{job['search']['generations_run']} generations)")
    return out | {"recovered_at": 1 if ok else None, "stop": stop, "final_speed_m_s": got.speed_m_s,
                  "final_fell": got.fell, "final_lateral_m": got.lateral_m, "final_yaw_deg": got.yaw_deg,
                  "tried": "the DE answer", "believed_forward_m": job["best"]["metrics"]["y_f_m"],
                  "believed_target_met": job["best"]["target_met"], "evaluations": job["timing"]["evaluations"],
                  "seconds": time.perf_counter() - t0}


def de_pass(p: Any, profile: Any, data: dict, log: Callable[[str], None]) -> str:
    """The DE arm on every reality of ``data`` that lacks it (in the file's order), each
    written as it finishes; the page's section rendered from the file. ``p``: the command's
    options (params.py ``Params``)."""
    from app.adapt.reproduce.report import render

    want = de_setup(p.quick)
    if data["setup"].get("de_believed") != want:  # another DE arm: run it again on every reality
        for r in data["realities"]:
            r["arms"].pop(DE_ARM, None)
        data["setup"]["de_believed"] = want
        write_json_atomic(p.json_out, data)
    for r in data["realities"]:  # the DE arm, after the rest: a reality's row is written first, then its DE
        if DE_ARM in r["arms"]:
            continue
        if p.stop_at and time.time() > p.stop_at:
            log(f"stopping before the DE arm on reality {r['id']}: --stop-at passed")
            break
        k = int(r["id"].rsplit("-", 1)[1])
        r["arms"][DE_ARM] = run_de_believed(r, p.seed * 100_003 + k, profile, p.quick)
        write_json_atomic(p.json_out, data)
        v = r["arms"][DE_ARM]
        log(f"reality {r['id']}: DE on the believed damage {v['seconds']:.0f} s, recovered {v['recovered_at']}, "
            f"{v['final_speed_m_s'] * 100:.1f} cm/s ({v['stop']})")
    return render(data)


def de_setup(quick: bool) -> dict:
    """The setup's entry of the DE arm: its words and the recovery spec's fixed fields."""
    return json.loads(json.dumps(DE_BELIEVED | {"spec": DE_QUICK if quick else DE_SPEC}))
