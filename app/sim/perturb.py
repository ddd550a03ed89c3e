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

The height field's cells are large compared with the feet (``terrain_cell_m``, 50 cm by
default), as MuJoCo's collider needs: it collides a geom with each triangular prism of the
field on its own, so a soft-contact foot (it sinks about 0.7 mm into the floor when it
stands) near an edge between two prisms also touches the neighbouring prism's top edge and
gets an extra contact tilted up to tens of degrees, on a floor that is flat there. On a
4 cm grid, with the recovery hexapod's 1 cm feet, a flat height field (amplitude 0) changed
the walk as much as the roughness did: 21 of Table II's 40 answers left the timestep
check's bands against the plane (19 moved forward by 5 % or more; drift moved by up to
14.5 cm, yaw by up to 18 deg; issue 47). With
50 cm cells a zero-amplitude floor reproduces the plane's walk within the timestep check's
tolerance, and so does a 0.5 mm floor (tests/jobs/recovery/test_held_out.py).

Beside the named cases, random models: ``RANDOM_RANGES`` states the ranges (friction,
masses, a payload and its place, servo strength and gains, a rough floor), ``draw_models``
draws them from a stream of a job's seed (``HELD_OUT_STREAM`` for the held-out set a job is
judged on, ``SEARCH_STREAM`` for a randomised search's draws, indexed by generation), and
``random_world`` / ``random_model`` turn a draw into a model of one size signature.

Models that differ only in model-level edits keep the nominal model's size signature, so
``mujoco.rollout`` can run them side by side, one model per batch element
(``same_signature``). A timestep change also changes the number of steps per second, so
such models are run in their own rollout call.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Sequence

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
    terrain_cell_m: float = 0.5  # large compared with the feet (see the module's text)
    terrain_half_size_m: float = 3.0
    terrain_seed: int = 0

    @property
    def structural(self) -> bool:
        return self.terrain_amplitude_m > 0.0


NOMINAL = Perturbation("nominal", "nominal model")
FLAT_M = 1e-9  # the elevation range of a zero-amplitude floor (MuJoCo wants a positive one)
# The rough floor's grid, in a named case and every random model: 50 cm, large compared with
# the feet, as MuJoCo's height-field collider needs (the module's text says why; on a 4 cm
# grid a flat floor alone changed the recovery hexapod's walk as much as the roughness, issue 47).
FLOOR_CELL_M = 0.5


# -- spec edits -----------------------------------------------------------------------------

def roughen_floor(spec: mujoco.MjSpec, p: Perturbation) -> mujoco.MjSpec:
    """Replaces the plane geom ``floor`` by a height field (same name, contact bits and
    friction; its explicit pairs name it, so they carry over) centred on it, heights
    uniform in [-a, a] at the grid's nodes, drawn from the perturbation's own seed so every
    re-run sees the same floor. At amplitude 0 the field is flat at the plane's height."""
    floor = spec.geom("floor")
    if floor is None:
        raise ValueError("rough terrain needs a plane geom named 'floor'")
    a = p.terrain_amplitude_m
    n = int(round(2 * p.terrain_half_size_m / p.terrain_cell_m)) + 1
    rng = np.random.default_rng(p.terrain_seed)
    heights = rng.random((n, n))  # in [0, 1]: elevation = base + h * size_z
    hf = spec.add_hfield(name="floor_rough", nrow=n, ncol=n,
                         size=[p.terrain_half_size_m, p.terrain_half_size_m, max(2 * a, FLAT_M), 0.05])
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


# -- random models: stated ranges, seeded draws, streams --------------------------------------

# The stated ranges every random model is drawn from, uniformly and independently. Friction:
# every geom's sliding friction; mass: every body's mass and inertia; payload: a share of the
# robot's mass on the torso, its centre offset in x and y; motor strength: every servo's torque
# limit; servo gains: every servo's kp, kd and ki together; floor: a height field of heights
# uniform in +-amplitude on a 50 cm grid. Not modelled: actuation latency, backlash, sensor noise.
RANDOM_RANGES = {
    "friction_scale": (0.6, 1.4),
    "mass_scale": (0.9, 1.1),
    "payload_share": (0.0, 0.15),
    "payload_x_m": (-0.03, 0.03),
    "payload_y_m": (-0.03, 0.03),
    "motor_strength": (0.7, 1.0),
    "servo_gain_scale": (0.7, 1.3),
    "floor_amplitude_m": (0.0, 0.005),
}
RANGE_TEXT = ("friction x 0.6-1.4, every mass x 0.9-1.1, payload 0-15 % of the robot's mass within 3 cm of the "
              "torso's centre in x and y, servo torque limits x 0.7-1.0, servo gains (kp, kd, ki) x 0.7-1.3, rough "
              "floor +-0-5 mm on a 50 cm grid")
# Streams of the job's seed no search draws from (the search uses the seed itself, the
# random-search control seed + 7919): the held-out set, and the randomised search's draws.
HELD_OUT_STREAM = 0x48454C44  # "HELD"
SEARCH_STREAM = 0x52414E44  # "RAND"


def draw_models(seed: int, n: int, stream: int = HELD_OUT_STREAM, generation: int = 0) -> list[dict[str, float]]:
    """``n`` random models (each a dict of RANDOM_RANGES' draws plus a floor seed), the same
    for the same (seed, stream, generation)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(stream), int(generation)]))
    out = []
    for _ in range(n):
        d = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in RANDOM_RANGES.items()}
        out.append(d | {"floor_seed": int(rng.integers(2**31))})
    return out


def random_world(mspec: mujoco.MjSpec) -> mujoco.MjModel:
    """The damaged robot on a height-field floor: the compiled structure every random model
    shares (one size signature, so a whole set runs in one rollout call)."""
    return perturbed_model(mspec, Perturbation("rough", "rough floor", terrain_amplitude_m=RANDOM_RANGES[
        "floor_amplitude_m"][1], terrain_cell_m=FLOOR_CELL_M))


def random_model(world: mujoco.MjModel, d: dict[str, float], robot_mass_kg: float) -> mujoco.MjModel:
    """One random model (a draw of ``draw_models``) of ``random_world``'s structure."""
    p = Perturbation("random", "random model", friction_scale=d["friction_scale"], mass_scale=d["mass_scale"],
                     payload_kg=d["payload_share"] * robot_mass_kg, payload_offset_m=(d["payload_x_m"],
                                                                                      d["payload_y_m"], 0.0))
    m = edit_model(world, p)
    m.actuator_forcerange[:] *= d["motor_strength"]
    m.actuator_biasprm[:, 1:3] *= d["servo_gain_scale"]  # -kp, -kd of MuJoCo's pid actuator
    m.actuator_gainprm[:, 0] *= d["servo_gain_scale"]  # ki
    a = d["floor_amplitude_m"]
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    hf = m.geom_dataid[floor]
    rows = slice(m.hfield_adr[hf], m.hfield_adr[hf] + m.hfield_nrow[hf] * m.hfield_ncol[hf])
    m.hfield_data[rows] = np.random.default_rng(d["floor_seed"]).random(rows.stop - rows.start)
    m.hfield_size[hf, 2] = max(2 * a, 1e-9)  # heights span [z - a, z + a] around the plane's height
    m.geom_pos[floor, 2] = world.geom_pos[floor, 2] + RANDOM_RANGES["floor_amplitude_m"][1] - a
    return m


def random_models(mspec: mujoco.MjSpec, draws: Sequence[dict[str, float]], robot_mass_kg: float) -> list[mujoco.MjModel]:
    world = random_world(mspec)
    return [random_model(world, d, robot_mass_kg) for d in draws]
