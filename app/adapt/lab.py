"""Measurements a lab types in, one trial a line, for adapting on a real robot:

    forward_m lateral_m yaw_deg fell duration_s

five fields separated by spaces: the robot's displacement in its start frame (m, forward
and to the left), its change of heading (deg, counter-clockwise), whether it fell (yes/no,
true/false or 1/0) and how long the gait ran (s). Each number finite and bounded; an error
names its field."""

from __future__ import annotations

import math

from app.adapt.reality import Measured
from app.jobs.base import SpecError

FIELDS = ("forward_m", "lateral_m", "yaw_deg", "fell", "duration_s")
BOUNDS = {"forward_m": (-100.0, 100.0), "lateral_m": (-100.0, 100.0), "yaw_deg": (-3600.0, 3600.0),
          "duration_s": (0.0, 3600.0)}
FELL = {"yes": True, "no": False, "true": True, "false": False, "1": True, "0": False}


def parse_line(line: str) -> Measured:
    parts = line.split()
    if len(parts) != len(FIELDS):
        raise SpecError([{"field": "measurement", "message": f"{len(parts)} values; give {len(FIELDS)}: "
                                                             f"{' '.join(FIELDS)}"}])
    out: dict = {}
    for name, text in zip(FIELDS, parts):
        if name == "fell":
            if text.lower() not in FELL:
                raise SpecError([{"field": name, "message": f"{text!r}: yes or no (true/false, 1/0)"}])
            out[name] = FELL[text.lower()]
            continue
        try:
            v = float(text)
        except ValueError:
            raise SpecError([{"field": name, "message": f"{text!r} is not a number"}]) from None
        lo, hi = BOUNDS[name]
        if not math.isfinite(v) or not lo <= v <= hi or (name == "duration_s" and v == 0):
            raise SpecError([{"field": name, "message": f"{text}: allowed {lo:g} {'<' if name == 'duration_s' else '<='} "
                                                        f"{name} <= {hi:g}, finite"}])
        out[name] = v
    return Measured(**out)
