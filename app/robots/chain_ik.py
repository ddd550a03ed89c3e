"""Batched numerical inverse kinematics of leg chains, numpy only (no MuJoCo, no gaitmend).

The solver of app/robots/numik.py (damped least squares on the transcribed ``mj_kinematics``
of each leg's chain; see its module doc), apart from the MuJoCo model it reads the chains
from, so that a robot runs the very IK the simulation ran: a recovery bundle ships this file
as ``controller/chain_ik.py`` beside ``gait_controller.py``, with the chains as data
(``ChainIK.as_dict`` / ``from_dict``: JSON, floats round-trip exactly).

A chain, per body from the trunk to the foot: its offset and rotation in its parent and its
joints (hinge or slide, unit axis, anchor in the body, qpos0); the foot point in the last
body. Joint values are the model's qpos (a hinge turns by q - qpos0 about its anchor, a
slide moves along its axis); targets are foot positions in the trunk's frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["ChainIK", "IKResult", "LegChain"]


@dataclasses.dataclass(frozen=True)
class IKResult:
    q: np.ndarray  # (..., nq): every leg joint, legs in the solver's order
    err: np.ndarray  # (..., legs): distance from each foot to its target after solving, m
    iterations: int  # the most any batch needed

    def reached(self, tol: float = 1e-6) -> np.ndarray:
        return self.err <= tol


def _skew(axis: np.ndarray) -> np.ndarray:
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _rm(R: np.ndarray, M: np.ndarray) -> np.ndarray:
    """R[n] @ M for a stack R (N, 3, 3) and one matrix or vector M: one BLAS call."""
    return (R.reshape(-1, 3) @ M).reshape(R.shape[0], 3, *M.shape[1:])


@dataclasses.dataclass(frozen=True)
class LegChain:
    """One leg, in the terms mj_kinematics uses: per body its offset and rotation in its
    parent, per joint (hinge?, unit axis, anchor in the body, qpos0); the foot in the last body."""

    bodies: list[tuple[np.ndarray, np.ndarray, list[tuple[bool, np.ndarray, np.ndarray, float]]]]
    foot: np.ndarray

    def kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Foot (N, 3), joint axes and anchors (N, K, 3) at joint values q (N, K), trunk frame."""
        n = len(q)
        R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        t = np.zeros((n, 3))
        axes, anchors, k = [], [], 0
        for pos, rot, joints in self.bodies:
            t = t + _rm(R, pos)
            R = _rm(R, rot)
            for hinge, axis, anchor, q0 in joints:
                a_w = _rm(R, axis)
                c_w = t + _rm(R, anchor)
                axes.append(a_w)
                anchors.append(c_w)
                if hinge:  # R Rot(axis, th) = R + sin(th) R K + (1 - cos(th)) R K^2 (Rodrigues)
                    K = _skew(axis)
                    th = (q[:, k] - q0)[:, None, None]
                    R = R + np.sin(th) * _rm(R, K) + (1.0 - np.cos(th)) * _rm(R, K @ K)
                    t = c_w - _rm(R, anchor)
                else:
                    t = t + a_w * (q[:, k] - q0)[:, None]
                k += 1
        return t + _rm(R, self.foot), np.stack(axes, axis=1), np.stack(anchors, axis=1)

    def as_dict(self) -> dict:
        return {"bodies": [{"pos": [float(v) for v in pos], "rot": np.asarray(rot, dtype=float).tolist(),
                            "joints": [{"hinge": bool(h), "axis": [float(v) for v in a],
                                        "anchor": [float(v) for v in c], "qpos0": float(q0)} for h, a, c, q0 in js]}
                           for pos, rot, js in self.bodies],
                "foot": [float(v) for v in self.foot]}

    @classmethod
    def from_dict(cls, d: dict) -> "LegChain":
        return cls([(np.array(b["pos"], dtype=float), np.array(b["rot"], dtype=float),
                     [(bool(j["hinge"]), np.array(j["axis"], dtype=float), np.array(j["anchor"], dtype=float),
                       float(j["qpos0"])) for j in b["joints"]]) for b in d["bodies"]],
                   np.array(d["foot"], dtype=float))


def _limit(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


class ChainIK:
    """Solves foot targets (..., legs, 3) for the chains' joints (see the module doc).

    ``lo`` / ``hi`` (nq,) the joint ranges (+-inf: unlimited; a joint with lo == hi is held
    there), ``q_ref`` (nq,) the start of every solve, ``floor`` (legs,) the damping's floor
    (m^2); ``damping`` and ``max_step`` the step's rule (app/robots/numik.py)."""

    def __init__(self, chains: list[LegChain], lo, hi, q_ref, floor, damping: float = 0.1, max_step: float = 0.5):
        self.chains = list(chains)
        self.lo, self.hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self.q_ref = np.asarray(q_ref, dtype=float)
        self.floor = np.asarray(floor, dtype=float)
        self.damping, self.max_step = float(damping), float(max_step)
        self._layout()

    def _layout(self) -> None:
        sizes = [sum(len(js) for *_, js in c.bodies) for c in self.chains]
        starts = np.cumsum([0] + sizes)
        self.cols = [slice(int(a), int(b)) for a, b in zip(starts[:-1], starts[1:])]
        self.nq, self.nlegs = int(starts[-1]), len(self.chains)

    # -- data ---------------------------------------------------------------------------
    def as_dict(self) -> dict:
        return {"chains": [c.as_dict() for c in self.chains], "lo": [_limit(v) for v in self.lo],
                "hi": [_limit(v) for v in self.hi], "q_ref": [float(v) for v in self.q_ref],
                "floor": [float(v) for v in self.floor], "damping": self.damping, "max_step": self.max_step}

    @classmethod
    def from_dict(cls, d: dict) -> "ChainIK":
        lo = [-np.inf if v is None else v for v in d["lo"]]
        hi = [np.inf if v is None else v for v in d["hi"]]
        return cls([LegChain.from_dict(c) for c in d["chains"]], lo, hi, d["q_ref"], d["floor"], d["damping"],
                   d["max_step"])

    def subset(self, legs: list[int]) -> "ChainIK":
        """The solver of legs ``legs`` (indices, in that order): each leg is solved alone, so
        its answers are those of the whole solver."""
        q = np.concatenate([np.arange(self.cols[i].start, self.cols[i].stop) for i in legs])
        return ChainIK([self.chains[i] for i in legs], self.lo[q], self.hi[q], self.q_ref[q], self.floor[legs],
                       self.damping, self.max_step)

    # -- kinematics ---------------------------------------------------------------------
    def fk(self, q: np.ndarray) -> np.ndarray:
        """Feet (..., legs, 3) in the trunk frame for joint values q (..., nq)."""
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, self.nq)
        feet = np.stack([c.kinematics(flat[:, s])[0] for c, s in zip(self.chains, self.cols)], axis=1)
        return feet.reshape(*q.shape[:-1], self.nlegs, 3)

    def jacobian(self, q: np.ndarray, leg: int) -> tuple[np.ndarray, np.ndarray]:
        """One leg's foot (N, 3) and position Jacobian (N, 3, K) at its joint values q (N, K)."""
        chain = self.chains[leg]
        foot, axes, anchors = chain.kinematics(q)
        hinge = np.array([h for *_, js in chain.bodies for h, *_ in js])
        cols = np.where(hinge[None, :, None], np.cross(axes, foot[:, None, :] - anchors), axes)
        return foot, np.swapaxes(cols, 1, 2)

    # -- solving ------------------------------------------------------------------------
    def _solve_leg(self, leg: int, target: np.ndarray, q: np.ndarray, tol: float, max_iter: int) -> tuple[np.ndarray, int]:
        s = self.cols[leg]
        lo, hi = self.lo[s], self.hi[s]
        active = np.arange(len(q))
        it = 0
        for it in range(1, max_iter + 1):
            foot, J = self.jacobian(q[active], leg)
            e = target[active] - foot
            norm = np.linalg.norm(e, axis=-1)
            done = norm <= tol
            active, J, e, norm = active[~done], J[~done], e[~done], norm[~done]
            if not len(active):
                break
            mu = self.damping * norm**2 + self.floor[leg]  # Levenberg-Marquardt: vanishes at a solution
            A = J @ np.swapaxes(J, 1, 2) + mu[:, None, None] * np.eye(3)
            dq = (np.swapaxes(J, 1, 2) @ np.linalg.solve(A, e[..., None]))[..., 0]
            big = np.abs(dq).max(axis=-1, keepdims=True)
            dq *= np.minimum(1.0, self.max_step / np.maximum(big, 1e-300))
            q[active] = np.clip(q[active] + dq, lo, hi)
        return q, it

    def solve(self, targets: np.ndarray, q0: np.ndarray | None = None, tol: float = 1e-10,
              max_iter: int = 50) -> IKResult:
        """Joint values reaching targets (..., legs, 3) (trunk frame, m), started from q0
        (..., nq) or from ``q_ref``."""
        targets = np.asarray(targets, dtype=float)
        if targets.shape[-2:] != (self.nlegs, 3):
            raise ValueError(f"targets must be (..., {self.nlegs}, 3), got {targets.shape}")
        lead = targets.shape[:-2]
        tg = targets.reshape(-1, self.nlegs, 3)
        start = self.q_ref if q0 is None else np.asarray(q0, dtype=float)
        q = np.clip(np.broadcast_to(start, (*lead, self.nq)).reshape(-1, self.nq), self.lo, self.hi)
        worst = 0
        for leg, s in enumerate(self.cols):
            q[:, s], it = self._solve_leg(leg, tg[:, leg], q[:, s].copy(), tol, max_iter)
            worst = max(worst, it)
        err = np.linalg.norm(self.fk(q) - tg, axis=-1)
        return IKResult(q=q.reshape(*lead, self.nq), err=err.reshape(*lead, self.nlegs), iterations=worst)
