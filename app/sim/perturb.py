"""Perturbed copies of a simulated world, for robustness checks and robust search.

Every kind re-simulates its final answer under the standard named cases
(``app.jobs.evidence.CASES``, the shared ``summary["robustness"]`` block), so a result that
only holds on the exact numerical model it was tuned on shows up as such. A kind turns each
case into a ``Perturbation`` of its MuJoCo world (the payload and the rough floor are the
kind's to size); ``perturbed_model`` turns an ``MjSpec`` into the perturbed ``MjModel``:

- structural edits go through a copy of the spec (rough terrain replaces the plane geom
  named ``floor`` by a height field with the same contact settings);
- the rest are edits of the compiled model (timestep, friction of every geom and explicit
  contact pair, masses and inertias of every body, a payload on one body), followed by
  ``mj_setConst`` so that the derived constants (subtree masses, inverse weights) match the
  new masses.

Models that differ only in model-level edits keep the nominal model's size signature, so
``mujoco.rollout`` can run them side by side, one model per batch element
(``same_signature``). A timestep change also changes the number of steps per second, so
such models are run in their own rollout call.
"""

from __future__ import annotations

import copy
import dataclasses
import mujoco
import numpy as np


@dataclasses.dataclass(frozen=True)
class Perturbation:
    name: str
    label: str
    timestep_scale: float = 1.0
    friction_scale: float = 1.0  # sliding friction of every geom
    mass_scale: float = 1.0  # mass and inertia of every body (same motors: a heavier robot)
    payload_kg: float = 0.0
    payload_body: str = "torso"
    payload_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)  # from the body's centre of mass
    terrain_amplitude_m: float = 0.0  # rough terrain: heights uniform in [-a, a]
    terrain_cell_m: float = 0.04
    terrain_half_size_m: float = 3.0
    terrain_seed: int = 0

    @property
    def structural(self) -> bool:
        return self.terrain_amplitude_m > 0.0


NOMINAL = Perturbation("nominal", "nominal model")


# -- spec edits -----------------------------------------------------------------------------

def roughen_floor(spec: mujoco.MjSpec, p: Perturbation) -> mujoco.MjSpec:
    """Replaces the plane geom ``floor`` by a height field (same name, contact bits and
    friction) centred on it, heights uniform in [-a, a] per cell, drawn from the
    perturbation's own seed so every re-run sees the same floor."""
    floor = spec.geom("floor")
    if floor is None:
        raise ValueError("rough terrain needs a plane geom named 'floor'")
    a = p.terrain_amplitude_m
    n = int(round(2 * p.terrain_half_size_m / p.terrain_cell_m)) + 1
    rng = np.random.default_rng(p.terrain_seed)
    heights = rng.random((n, n))  # in [0, 1]: elevation = base + h * size_z
    hf = spec.add_hfield(name="floor_rough", nrow=n, ncol=n,
                         size=[p.terrain_half_size_m, p.terrain_half_size_m, 2 * a, 0.05])
    hf.userdata = heights.ravel().tolist()
    pos = np.asarray(floor.pos, dtype=float).copy()
    pos[2] -= a  # the surface spans [z - a, z + a] around the plane's height
    kw = dict(contype=floor.contype, conaffinity=floor.conaffinity, friction=list(floor.friction),
              condim=floor.condim, rgba=list(floor.rgba))
    spec.delete(floor)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="floor_rough",
                            pos=pos.tolist(), **kw)
    return spec


# -- model edits ----------------------------------------------------------------------------

def _add_payload(model: mujoco.MjModel, p: Perturbation) -> None:
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.payload_body)
    if b < 0:
        raise ValueError(f"payload body {p.payload_body!r} not in the model")
    M, m = float(model.body_mass[b]), p.payload_kg
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, model.body_iquat[b])
    R = R.reshape(3, 3)
    I_body = R @ np.diag(model.body_inertia[b]) @ R.T  # about the old com, body axes
    c_old = model.body_ipos[b].copy()
    c_pay = c_old + np.asarray(p.payload_offset_m)
    c_new = (M * c_old + m * c_pay) / (M + m)

    def shift(I, mass, d):  # parallel axis theorem: inertia about a point d away
        return I + mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

    I_new = shift(I_body, M, c_old - c_new) + shift(np.zeros((3, 3)), m, c_pay - c_new)
    w, V = np.linalg.eigh(I_new)
    if np.linalg.det(V) < 0:
        V[:, 0] *= -1
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, V.ravel())
    model.body_mass[b] = M + m
    model.body_ipos[b] = c_new
    model.body_inertia[b] = w
    model.body_iquat[b] = q


def edit_model(model: mujoco.MjModel, p: Perturbation) -> mujoco.MjModel:
    """A perturbed copy of a compiled model (model-level edits only)."""
    m = copy.copy(model)
    m.opt.timestep = model.opt.timestep * p.timestep_scale
    m.geom_friction[:, 0] *= p.friction_scale
    m.pair_friction[:, :2] *= p.friction_scale  # explicit pairs (app/robots/contacts.py): both tangent directions
    if p.mass_scale != 1.0:
        m.body_mass[1:] *= p.mass_scale
        m.body_inertia[1:] *= p.mass_scale
    if p.payload_kg:
        _add_payload(m, p)
    if p.mass_scale != 1.0 or p.payload_kg:
        mujoco.mj_setConst(m, mujoco.MjData(m))
    return m


def perturbed_model(spec: mujoco.MjSpec, p: Perturbation, model: mujoco.MjModel | None = None) -> mujoco.MjModel:
    """The world of ``spec`` under ``p``. ``model`` (the compiled spec) saves a compile when
    ``p`` needs no structural edit."""
    if p.structural:
        base = roughen_floor(spec.copy(), p).compile()
    else:
        base = model if model is not None else spec.copy().compile()
    return edit_model(base, p)


def same_signature(a: mujoco.MjModel, b: mujoco.MjModel) -> bool:
    """Can ``a`` and ``b`` share one ``mujoco.rollout`` call (same sizes and timestep)?"""
    sizes = ("nq", "nv", "nu", "na", "nbody", "ngeom", "nsensordata", "nhfielddata", "nmocap", "neq")
    return a.opt.timestep == b.opt.timestep and all(getattr(a, s) == getattr(b, s) for s in sizes)
