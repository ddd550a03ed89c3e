"""Gait-sequence planning (paper 000, Algorithms 1-3, Remark 1).

A sequence splits one gait period into ``sigma`` equal phases and gives every functional
leg the phase in which it swings; in the other phases it supports.

Algorithm 2 as typeset sets ``lambda`` to the second leg of the intact group, so one leg
swings twice and another never (papers README). What it intends, and what we build: the
five legs are spread over three phases, every leg swings exactly once per period, no two
neighbouring legs swing together (the "rule of neighbourhood", neighbours being the
adjacent legs on the same side and the opposite leg of the same pair), and at least
three legs support at all times. Where several assignments satisfy that, the one whose
support polygons hold the centre of mass with the largest worst-case margin wins.

The same search is the general planner of Remark 1 for any leg count and loss pattern.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence

import numpy as np

TRIPOD_L1 = (1, 4, 5)
TRIPOD_L2 = (2, 3, 6)
MIN_SUPPORT = 3


class InfeasibleMorphology(ValueError):
    """The damaged robot cannot walk statically with any gait sequence."""


@dataclasses.dataclass(frozen=True)
class GaitSequence:
    name: str
    sigma: int
    swing_phase: Mapping[int, int]  # leg -> phase index in [0, sigma)

    @property
    def legs(self) -> list[int]:
        return sorted(self.swing_phase)

    def groups(self) -> list[list[int]]:
        return [sorted(l for l, p in self.swing_phase.items() if p == k) for k in range(self.sigma)]

    def support(self, phase: int) -> list[int]:
        return sorted(l for l, p in self.swing_phase.items() if p != phase)

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "sigma": self.sigma,
            "swing_phases": {str(l): p for l, p in sorted(self.swing_phase.items())},
            "groups": self.groups(),
        }


def hexapod_neighbours(leg: int) -> set[int]:
    """Adjacent legs on the same side and the opposite leg of the same pair."""
    out = {leg + 2, leg - 2, leg + 1 if leg % 2 else leg - 1}
    return {n for n in out if 1 <= n <= 6}


def side_of(leg: int) -> int:
    return -1 if leg % 2 else 1


def check_feasible(functional: Sequence[int]) -> None:
    n = len(functional)
    odd = sum(1 for l in functional if l % 2)
    even = n - odd
    if n < 4 or odd < 2 or even < 2:
        raise InfeasibleMorphology(
            f"infeasible morphology: {n} functional legs ({odd} odd/left, {even} even/right); "
            "static walking needs at least 4 legs with at least 2 on each side"
        )


def support_margin(points: np.ndarray, com: np.ndarray) -> float:
    """Signed distance from com to the boundary of the convex hull of points (2-D);
    positive inside. Fewer than three points, or collinear ones, give -inf."""
    if len(points) < 3:
        return -math.inf
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except QhullError:
        return -math.inf
    # hull.equations rows are (n, c) with n.x + c <= 0 inside and |n| = 1.
    return float(-(hull.equations[:, :2] @ com + hull.equations[:, 2]).max())


def plan_general(
    functional: Sequence[int],
    feet_xy: Mapping[int, Sequence[float]],
    neighbours=hexapod_neighbours,
    com_xy: Sequence[float] = (0.0, 0.0),
    name: str = "general",
) -> GaitSequence:
    """Smallest sigma for which an assignment exists with every leg swinging once, no
    neighbours together, >= 3 supporting legs; best worst-case support margin wins."""
    legs = sorted(functional)
    n = len(legs)
    if n < MIN_SUPPORT + 1:
        raise InfeasibleMorphology(f"infeasible morphology: {n} legs cannot keep {MIN_SUPPORT} in support while one swings")
    com = np.asarray(com_xy, dtype=float)
    pts = {l: np.asarray(feet_xy[l], dtype=float) for l in legs}
    nbr = {l: set(neighbours(l)) & set(legs) for l in legs}
    sigma = max(2, math.ceil(n / (n - MIN_SUPPORT)))
    while sigma <= n:
        best = None
        # Leg legs[0] swings in phase 0: removes the relabelling symmetry of phases.
        for rest in itertools.product(range(sigma), repeat=n - 1):
            assign = (0, *rest)
            groups = [[legs[i] for i in range(n) if assign[i] == k] for k in range(sigma)]
            if any(not g or n - len(g) < MIN_SUPPORT for g in groups):
                continue
            if any(b in nbr[a] for g in groups for a, b in itertools.combinations(g, 2)):
                continue
            # Phases run in order of their lowest leg index, so equal partitions compare equal.
            groups.sort(key=min)
            key = tuple(tuple(g) for g in groups)
            margin = min(
                support_margin(np.array([pts[l] for l in legs if l not in g]), com) for g in groups
            )
            if margin == -math.inf:
                continue
            score = (margin, tuple(-len(g) for g in groups))
            if best is None or score > best[0] or (score == best[0] and key < best[1]):
                best = (score, key)
        if best is not None:
            phase = {l: k for k, g in enumerate(best[1]) for l in g}
            return GaitSequence(name=name, sigma=sigma, swing_phase=phase)
        sigma += 1
    raise InfeasibleMorphology(f"no gait sequence keeps {MIN_SUPPORT} legs in support for legs {legs}")


def plan_hexapod(lost_legs: Sequence[int], feet_xy: Mapping[int, Sequence[float]],
                 com_xy: Sequence[float] = (0.0, 0.0)) -> GaitSequence:
    """Algorithm 1: nominal tripod, modified quadrangular (one leg lost) or modified
    pentagonal (two legs lost) sequence for a hexapod."""
    functional = [l for l in range(1, 7) if l not in set(lost_legs)]
    check_feasible(functional)
    n = len(functional)
    if n == 6:
        return nominal_tripod(functional)
    if n == 5:
        return plan_general(functional, feet_xy, hexapod_neighbours, com_xy, name="modified_quadrangular")
    # Algorithm 3: one leg at a time, in index order.
    return GaitSequence("modified_pentagonal", 4, {l: k for k, l in enumerate(functional)})


def nominal_tripod(functional: Sequence[int]) -> GaitSequence:
    """The healthy robot's tripod: L1 swings in the first half period, L2 in the second.
    Applied unchanged to a damaged robot it is the paper's "before recovery" baseline."""
    return GaitSequence("tripod", 2, {l: (0 if l in TRIPOD_L1 else 1) for l in functional})
