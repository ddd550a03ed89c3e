"""Explicit contact pairs in place of MuJoCo's broad phase, where that is the same physics.

A legged robot on a floor collides with the floor only: its links never touch each other
(contype/conaffinity keep them apart). MuJoCo still runs its broad phase every step to find
those few robot-floor pairs, and on the recovery hexapod that costs about a tenth of the
step (docs/recovery_speed.md, "Changes and their gains"). ``explicit_pairs`` lists, once, every
geom pair the broad phase could ever hand to the narrow phase (MuJoCo's filters: not the same
welded body, not a welded parent and child, contype/conaffinity, excluded body pairs), and
when each of them has a static world geom on one side (a floor, a wall; the robot's pairs
with itself would make the set grow with its pose, so then nothing changes), it declares
them as ``<pair>`` elements with the contact parameters MuJoCo's mixing rule gives that pair
(``mj_contactParam``: priority, else the largest condim, friction and margin and gap, solref
and solimp mixed by solmix), and clears every geom's contype and conaffinity. The narrow
phase then sees the same pairs with the same parameters, and the simulation is the same bit
for bit (tests/robots/test_contacts.py) while the broad phase has nothing left to do.

Parameters of a pair are fixed when the spec compiles: a later edit of a compiled model's
geom friction must scale ``pair_friction`` too (``app.sim.perturb.edit_model`` does).
Structural edits that replace a world geom by name (the rough floor) keep its pairs.
"""

from __future__ import annotations

import mujoco
import numpy as np

MAX_PAIRS = 64  # more than this and the broad phase's culling is worth its cost: leave it
_MINVAL = 1e-15  # mjMINVAL


def candidate_pairs(model: mujoco.MjModel) -> list[tuple[int, int]]:
    """Every geom pair (g1 < g2) MuJoCo's broad phase could pass to the narrow phase."""
    weld = model.body_weldid
    wparent = weld[model.body_parentid[weld]]
    filterparent = not (model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    excluded = {int(s) for s in model.exclude_signature}
    explicit = {(int(a), int(b)) for a, b in zip(model.pair_geom1, model.pair_geom2)}
    out = []
    for g1 in range(model.ngeom):
        for g2 in range(g1 + 1, model.ngeom):
            ct1, ca1 = model.geom_contype[g1], model.geom_conaffinity[g1]
            ct2, ca2 = model.geom_contype[g2], model.geom_conaffinity[g2]
            if not ((ct1 & ca2) or (ct2 & ca1)):
                continue
            b1, b2 = int(model.geom_bodyid[g1]), int(model.geom_bodyid[g2])
            w1, w2 = int(weld[b1]), int(weld[b2])
            if w1 == w2:
                continue
            if filterparent and w1 != 0 and w2 != 0 and (w1 == wparent[w2] or w2 == wparent[w1]):
                continue
            if ((b1 << 16) + b2 in excluded or (b2 << 16) + b1 in excluded  # either order of the signature
                    or (g1, g2) in explicit or (g2, g1) in explicit):
                continue
            out.append((g1, g2))
    return out


def mixed_parameters(model: mujoco.MjModel, g1: int, g2: int) -> dict:
    """The contact parameters MuJoCo gives a dynamic contact between ``g1`` and ``g2``
    (``mj_contactParam`` and the margin of ``mj_collideGeoms``), as ``<pair>`` attributes."""
    gap = max(model.geom_gap[g1], model.geom_gap[g2])
    margin = max(model.geom_margin[g1], model.geom_margin[g2])
    p1, p2 = model.geom_priority[g1], model.geom_priority[g2]
    if p1 != p2:
        g = g1 if p1 > p2 else g2
        condim = int(model.geom_condim[g])
        solref = model.geom_solref[g].tolist()
        solimp = model.geom_solimp[g].tolist()
        fri = model.geom_friction[g].tolist()
    else:
        condim = int(max(model.geom_condim[g1], model.geom_condim[g2]))
        s1, s2 = model.geom_solmix[g1], model.geom_solmix[g2]
        if s1 >= _MINVAL and s2 >= _MINVAL:
            mix = s1 / (s1 + s2)
        elif s1 < _MINVAL and s2 < _MINVAL:
            mix = 0.5
        else:
            mix = 0.0 if s1 < _MINVAL else 1.0
        r1, r2 = model.geom_solref[g1], model.geom_solref[g2]
        if r1[0] > 0 and r2[0] > 0:
            solref = [mix * a + (1 - mix) * b for a, b in zip(r1, r2)]
        else:
            solref = [min(a, b) for a, b in zip(r1, r2)]
        solimp = [a * mix + b * (1 - mix) for a, b in zip(model.geom_solimp[g1], model.geom_solimp[g2])]
        fri = [max(a, b) for a, b in zip(model.geom_friction[g1], model.geom_friction[g2])]
    return {"condim": condim, "friction": [fri[0], fri[0], fri[1], fri[2], fri[2]], "solref": [float(v) for v in solref],
            "solimp": [float(v) for v in solimp], "margin": float(margin), "gap": float(gap)}


def explicit_pairs(spec: mujoco.MjSpec) -> bool:
    """Replaces the broad phase of ``spec`` by explicit pairs where that is exact (see the
    module's text); edits ``spec`` in place. True if it did; False, leaving ``spec`` alone,
    when some possible pair has no static world geom, a geom of one has no name, the set
    is larger than ``MAX_PAIRS`` or the model has flexes."""
    model = spec.compile()
    if model.nflex:
        return False
    pairs = candidate_pairs(model)
    static = np.asarray(model.body_weldid)[model.geom_bodyid] == 0
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(model.ngeom)]
    if not pairs or len(pairs) > MAX_PAIRS or not all(static[a] or static[b] for a, b in pairs) \
            or not all(names[a] and names[b] for a, b in pairs):
        return False
    for g1, g2 in pairs:
        spec.add_pair(geomname1=names[g1], geomname2=names[g2], **mixed_parameters(model, g1, g2))
    for g in spec.geoms:
        g.contype, g.conaffinity = 0, 0
    return True
