"""Force-Angle Stability Measure (Papadopoulos & Rey 1996; paper 002 Eq. 3-9), tipping
judgment with the 20 deg threshold and the time-to-tip estimate (Eq. 15).

Sign convention (the copy's Eq. 8 is garbled; this is P&R's intent): support feet are
ordered counter-clockwise seen from above, so the outside of edge i lies to the right of
a_i. The angle is positive while the tipping force f_i* points inside the stability
polyhedron's face, i.e. while (l_i x f_i*) . a_i > 0, zero when the robot balances on the
edge, and negative once it tips about it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.jobs.tipping.stability.polygon import cross3, edge_frames


def net_wrench_from_contacts(feet: np.ndarray, forces: np.ndarray, com: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 4: f_r = -sum f_sup, n_r = -sum n_sup (moments about the CoM). ``forces`` are the
    ground's forces on the robot at ``feet``; shapes (..., m, 3). The support wrench balances
    gravity, inertia and external loads, so this is their sum as a force sensor sees it."""
    forces = np.asarray(forces, float)
    r = np.asarray(feet, float) - np.asarray(com, float)[..., None, :]
    return -forces.sum(axis=-2), -cross3(r, forces).sum(axis=-2)


def net_wrench_from_loads(mass: float, gravity: np.ndarray, com_acc: np.ndarray, f_ext: np.ndarray | None = None,
                          n_inertial: np.ndarray | None = None, n_ext: np.ndarray | None = None):
    """Eq. 4's left side: f_r = m g + f_ext - m a, n_r = n_ext + n_I (gravity has no moment
    about the CoM)."""
    f = mass * (np.asarray(gravity, float) - np.asarray(com_acc, float))
    if f_ext is not None:
        f = f + f_ext
    n = np.zeros_like(f)
    for extra in (n_inertial, n_ext):
        if extra is not None:
            n = n + extra
    return f, n


def fasm_edges(feet: np.ndarray, com: np.ndarray, f_r: np.ndarray, n_r: np.ndarray) -> np.ndarray:
    """Signed angle theta_i (radians) per support edge, Eq. 5-8. Batched: feet (..., k, 3)
    counter-clockwise, com/f_r/n_r (..., 3); returns (..., k). Edge i joins feet i and i+1."""
    a, l = edge_frames(feet, com)
    ln = np.linalg.norm(l, axis=-1, keepdims=True)
    lh = l / ln
    f_r = np.asarray(f_r, float)[..., None, :]
    n_r = np.asarray(n_r, float)[..., None, :]
    f_i = f_r - a * np.sum(a * f_r, axis=-1, keepdims=True)  # Eq. 5
    n_i = a * np.sum(a * n_r, axis=-1, keepdims=True)
    f_star = f_i + cross3(lh, n_i) / ln  # Eq. 6-7
    fs = f_star / np.maximum(np.linalg.norm(f_star, axis=-1, keepdims=True), 1e-12)
    cosang = np.clip(np.sum(lh * fs, axis=-1), -1.0, 1.0)
    sign = np.where(np.sum(cross3(lh, fs) * a, axis=-1) > 0.0, 1.0, -1.0)
    return sign * np.arccos(cosang)


def fasm(feet: np.ndarray, com: np.ndarray, f_r: np.ndarray, n_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 9: (margin in degrees, index of the critical edge), batched like ``fasm_edges``."""
    th = np.degrees(fasm_edges(feet, com, f_r, n_r))
    i = np.argmin(th, axis=-1)
    return np.take_along_axis(th, i[..., None], axis=-1)[..., 0], i


def time_to_tip(margin_deg: float, rate: float, acc: float, kappa: float = 0.8) -> float:
    """Eq. 15: the time for the margin to fall from its current value to zero, extrapolating
    S(t) = S + v t + a t^2 / 2 (the copy's quadratic drops the 1/2 and writes the threshold
    for S; the intent is the root of the margin's own Taylor model), scaled by kappa in (0, 1).
    Falls back to the linear estimate when the quadratic has no positive root; inf when the
    margin is not falling."""
    s, v, a = float(margin_deg), float(rate), float(acc)
    if s <= 0:
        return 0.0
    roots = []
    if abs(a) > 1e-9:
        disc = v * v - 2.0 * a * s
        if disc >= 0:
            q = np.sqrt(disc)
            roots = [t for t in ((-v + q) / a, (-v - q) / a) if t > 0]
    if roots:
        return kappa * min(roots)
    if v < 0:
        return kappa * (-s / v)
    return float("inf")


@dataclasses.dataclass
class TipDetector:
    """Judgment (Sec. 3): tipping when S_FASM < threshold. Keeps a short history so the
    margin's rate and acceleration (Eq. 15) come from a least-squares quadratic over the
    last ``window`` samples, which is far less noisy than finite differences of contact
    forces."""

    threshold_deg: float = 20.0
    kappa: float = 0.8
    window: int = 25
    times: list = dataclasses.field(default_factory=list)
    margins: list = dataclasses.field(default_factory=list)

    def update(self, t: float, margin_deg: float) -> bool:
        self.times.append(float(t))
        self.margins.append(float(margin_deg))
        if len(self.times) > self.window:
            self.times.pop(0)
            self.margins.pop(0)
        return margin_deg < self.threshold_deg

    def rates(self) -> tuple[float, float]:
        """Margin rate and acceleration at the newest sample. The acceleration is kept only
        where the quadratic term is significant (|a| > 2 standard errors of the least-squares
        fit): over half a second of contact-force-based margins an insignificant curvature is
        noise: on a platform turning at a constant rate (the margin then falls linearly)
        it moved the Eq. 15 estimate from 3.2 to 2.0 s between physics steps of 2 and
        0.5 ms; with this rule 1.7-1.8 s at every step."""
        if len(self.times) < 3:
            return 0.0, 0.0
        t = np.asarray(self.times) - self.times[-1]
        m = np.asarray(self.margins)
        if len(t) > 4:  # the fit's covariance needs more points than coefficients + 2
            (c2, c1, _), cov = np.polyfit(t, m, 2, cov=True)
            if abs(c2) > 2.0 * np.sqrt(max(cov[0, 0], 0.0)):
                return float(c1), float(2.0 * c2)
        c1, _ = np.polyfit(t, m, 1)
        return float(c1), 0.0

    def time_to_tip(self) -> float:
        v, a = self.rates()
        return time_to_tip(self.margins[-1], v, a, self.kappa)
