"""The machine a measurement ran on, as benchmark and speed records keep it beside their
figures: wall times from hosts sold under one CPU name are not comparable without it."""

from __future__ import annotations

import os
import platform
from pathlib import Path


def machine() -> dict:
    """The CPU model (/proc/cpuinfo's, else the platform's word for it), its family and model
    numbers where /proc/cpuinfo gives them (hosts sold under one name differ in speed: "AMD
    EPYC" is family 25 on one and 26 on another), and the core count."""
    out = {"cpu": platform.processor() or platform.machine()}
    keys = {"model name": "cpu", "cpu family": "cpu_family", "model": "cpu_model"}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, val = line.partition(":")
            name = keys.pop(key.strip(), None)
            if name is not None:
                out[name] = val.strip() if name == "cpu" else int(val)
            if not keys:
                break
    except (OSError, ValueError):
        pass
    return out | {"cores": os.cpu_count(), "python": platform.python_version()}


def machine_text(m: dict, cores: bool = True) -> str:
    """"AMD EPYC, family 26 model 2, 2 cores": the parts the run recorded (family and model,
    even the CPU's name, are missing from older records); ``cores`` False leaves the cores out."""
    parts = [m.get("cpu")]
    if "cpu_family" in m and "cpu_model" in m:
        parts.append(f"family {m['cpu_family']} model {m['cpu_model']}")
    if cores:
        parts.append(f"{m['cores']} cores")
    return ", ".join(p for p in parts if p)
