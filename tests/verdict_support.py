"""Two recovery jobs whose held-out figure is low or high by construction (issue 46), for the
CLI, client, study and browser tests of the verdict. The held-out models' floor and ranges
are being tuned (app/jobs/recovery/cases.py), so neither job relies on a scenario that
happens to land low or high today:

- FRAGILE: legs 3 and 4 lost, the search's step length capped at 4 mm. At a 0.6 s period a
  4 s walk cannot reach the 20 cm the target asks (the best reaches ~3 cm on every model),
  so the held-out models cannot keep the target: 0 of 20, whatever the floor.
- ROBUST: no damage, the fast preset, a 4 s walk: the tripod walks 47-49 cm against 20 cm,
  drifts at most 0.6 cm against 2 cm and turns at most 1.9 deg against 4 deg on every
  held-out model (measured at the time of writing), and none falls.

Each takes 5-15 s of one core.

``summary(met, fell)``: a summary of no kind in particular whose robustness block carries a
held-out set of 20 models (met keep the target, fell fall), for the verdict's unit tests."""

from app.jobs.records import Robustness

FRAGILE = {"kind": "recovery", "damage": {"lost_legs": [3, 4]},
           "search": {"population": 6, "generations": 2, "seed": 1}, "sim": {"duration_s": 4.0},
           "bounds": {"step_length_m": [0.0, 0.004]}}
ROBUST = {"kind": "recovery", "damage": {"lost_legs": []}, "preset": "fast", "sim": {"duration_s": 4.0}}


TARGET = "forward >= 50 cm and no fall"


def _models(met: int, fell: int, n: int = 20, unjudged: int = 0) -> list[dict]:
    """n held-out models: ``fell`` fall (missing the target), ``met`` keep it, ``unjudged``
    are not judged, the rest miss it upright."""
    out = []
    for i in range(n):
        f = i < fell
        tm = False if f else (True if i < fell + met else None if i < fell + met + unjudged else False)
        out.append({"draw": {"friction_scale": 1.0}, "metrics": {"y_f_m": 0.6, "fell": f}, "target_met": tm})
    return out


def summary(met: int, fell: int, n: int = 20, unjudged: int = 0, held: bool = True) -> dict:
    cases = [{"name": "dt_half", "label": "timestep halved", "metrics": {"y_f_m": 0.6}, "target_met": True},
             {"name": "dt_quarter", "label": "timestep quartered", "metrics": {"y_f_m": 0.6}, "target_met": True},
             {"name": "friction_0.7", "label": "friction x 0.7", "metrics": {"y_f_m": 0.6}, "target_met": True},
             {"name": "payload", "label": "payload", "metrics": {"y_f_m": 0.4}, "target_met": False}]
    extra = {"held_out": {"n": n, "met": met, "share": met / n, "models": _models(met, fell, n, unjudged)}} if held else {}
    rob = Robustness.build(TARGET, {"y_f_m": 0.6}, cases, **extra).to_json()
    return {"target": TARGET, "target_met": True, "robustness": rob, "controls": []}
