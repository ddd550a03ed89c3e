"""What the sandboxed process does with the sanitised model: compile it, check the compiled
sizes against the caps, and find (or check) its legs. Runs only inside child.py."""

from __future__ import annotations

import re

import mujoco
import numpy as np

from app.robots.detect import check_legs, detect_legs, leg_points
from app.robots.legmap import LegMap, LegMapError


def scrub(message: str, assets: dict[str, bytes]) -> str:
    """MuJoCo words a missing file and an unreadable one differently ("Error opening file"
    against "empty PNG file": it can still stat what it may not open). A message about a
    file that is not one of the assets says only that, the same whatever the host holds."""
    quoted = re.findall(r"'([^']*)'", message)
    names = [q for q in quoted if "/" in q or "." in q]
    if re.search(r"file|open", message, re.IGNORECASE) and any(n not in assets for n in names):
        return "the model references a file that is not one of the uploaded files"
    return message


def _caps(model: mujoco.MjModel, lim: dict) -> str | None:
    checks = [
        ("bodies", model.nbody - 1, lim["max_bodies"]), ("joints", model.njnt, lim["max_joints"]),
        ("geoms", model.ngeom, lim["max_geoms"]), ("actuators", model.nu, lim["max_actuators"]),
        ("mesh vertices", model.nmeshvert, lim["max_mesh_vertices"]),
        ("mesh faces", model.nmeshface, lim["max_mesh_faces"]),
        ("height-field samples", model.nhfielddata, lim["max_hfield_data"]),
        ("texture bytes", model.ntexdata, lim["max_texture_bytes"]),
        ("arena bytes (the simulation's memory)", model.narena, lim["max_arena_bytes"]),
        ("solver iterations", model.opt.iterations, lim["max_iterations"]),
        ("line-search iterations", model.opt.ls_iterations, lim["max_iterations"]),
        ("noslip iterations", model.opt.noslip_iterations, lim["max_iterations"]),
        ("ccd iterations", model.opt.ccd_iterations, lim["max_iterations"]),
    ]
    for what, n, cap in checks:
        if n > cap:
            return f"the compiled model has {int(n)} {what}; the cap is {cap}"
    if model.nplugin != 0:
        return "the compiled model uses plugins; they are refused"
    if not lim["min_timestep"] <= model.opt.timestep <= lim["max_timestep"]:
        return (f"timestep {model.opt.timestep:g} s is outside [{lim['min_timestep']:g}, {lim['max_timestep']:g}] s")
    if not np.isfinite(model.stat.extent) or model.stat.extent > lim["max_extent_m"]:
        return f"the model spans {model.stat.extent:g} m; the cap is {lim['max_extent_m']:g} m"
    return None


def stats(model: mujoco.MjModel) -> dict:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    kinds = {}
    for a in range(model.nu):
        affine = int(model.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_AFFINE)
        fixed = int(model.actuator_gaintype[a]) == int(mujoco.mjtGain.mjGAIN_FIXED)
        key = "position servo" if affine else "motor" if fixed else "other"
        kinds[key] = kinds.get(key, 0) + 1
    return {"bodies": int(model.nbody - 1), "joints": int(model.njnt), "geoms": int(model.ngeom),
            "actuators": int(model.nu), "actuator_kinds": kinds, "meshes": int(model.nmesh),
            "mesh_vertices": int(model.nmeshvert), "textures": int(model.ntex), "hfields": int(model.nhfield),
            "arena_bytes": int(model.narena), "timestep_s": float(model.opt.timestep),
            "total_mass_kg": round(float(np.sum(model.body_mass)), 6), "extent_m": round(float(model.stat.extent), 6)}


def examine(xml: str, assets: dict[str, bytes], legs: dict | None, forward: str | None, lim: dict) -> dict:
    try:
        model = mujoco.MjSpec.from_string(xml, assets=assets).compile()
    except MemoryError:
        raise
    except Exception as e:  # MuJoCo's compile error: its text names the element at fault
        return {"ok": False, "error": "MuJoCo cannot compile the model: " + scrub(str(e).strip(), assets)[:600]}
    problem = _caps(model, lim)
    if problem:
        return {"ok": False, "error": problem}
    try:
        if legs is not None:
            leg_map = LegMap.parse(legs)
            check_legs(model, leg_map)
            detected = False
        else:
            leg_map = detect_legs(model, forward)
            detected = True
        points = leg_points(model, leg_map)
    except LegMapError as e:
        hint = "" if legs is not None else " (give the leg map as JSON: --legs / the legs field)"
        return {"ok": False, "error": f"legs: {e}{hint}", "field": "legs"}
    return {"ok": True, "legs": leg_map.to_json(), "detected": detected, "points": points, "stats": stats(model)}
