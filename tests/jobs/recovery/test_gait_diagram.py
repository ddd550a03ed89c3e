"""The gait diagram shows the planned swing beside the measured contact, on the page and in
the bundle's PNG, in one colour scheme (issue 25): a foot the plan lifts but that never
leaves the ground shows a planned bar with no measured swing under it."""

import numpy as np
import pytest
from PIL import Image

from app.jobs.recovery import plots, views
from app.jobs.recovery.gaitplan import GAIT_SCHEME, faded, plan_of, planned_swings

TRIPOD = {"name": "tripod", "sigma": 2, "swing_phases": {"1": 0, "2": 1}, "groups": [[1], [2]]}


def trace() -> dict:
    """1.2 s at 10 ms: leg 1 swings as planned (first half of each 0.6 s period), leg 2 never lifts."""
    t = np.arange(0, 1.2, 0.01)
    leg1 = np.mod(t / 0.6, 1.0) >= 0.5
    return {"time_s": t, "foot_contact": np.stack([leg1, np.ones_like(leg1)], axis=1), "legs": np.array([1, 2])}


def summary() -> dict:
    return {"gait": TRIPOD | {"period_s": 0.6}, "baseline": {"gait": TRIPOD}}


def _swings_by_sampling(gait: dict, period: float, leg: int, t_end: float) -> list[tuple[float, float]]:
    """The slow reference: a leg with phase p of sigma swings while floor(sigma * (t / period mod 1)) == p;
    sampled every 1e-4 s, the runs of swinging samples are its swings (ends to within a sample)."""
    p = gait["swing_phases"].get(str(leg))
    if p is None:
        return []
    t = np.arange(0.0, t_end + 1e-9, 1e-4)
    on = np.floor(gait["sigma"] * np.mod(t / period + 1e-9, 1.0)) == p
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    return [(t[a], t[min(b, len(t) - 1)]) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _ends(swings) -> list[float]:
    return [x for ab in swings for x in ab]


def test_planned_swings_follow_the_sequence():
    # by hand: phase p of sigma swings over [(c + p / sigma) T, (c + (p + 1) / sigma) T), clipped at the end
    assert _ends(planned_swings(TRIPOD, 0.6, 2, 1.2)) == pytest.approx(_ends([(0.3, 0.6), (0.9, 1.2)]))
    assert _ends(planned_swings(TRIPOD, 0.6, 1, 1.0)) == pytest.approx(_ends([(0.0, 0.3), (0.6, 0.9)]))
    # cut by the end
    assert _ends(planned_swings(TRIPOD, 0.6, 2, 1.05)) == pytest.approx(_ends([(0.3, 0.6), (0.9, 1.05)]))
    assert planned_swings(TRIPOD, 0.6, 3, 1.0) == []
    wave = {"sigma": 3, "swing_phases": {"1": 0, "2": 2, "3": 1}}
    assert _ends(planned_swings(wave, 0.9, 2, 2.0)) == pytest.approx(_ends([(0.6, 0.9), (1.5, 1.8)]))
    for gait, period, t_end in ((TRIPOD, 0.6, 1.25), (TRIPOD, 0.7, 2.35), (wave, 0.9, 2.0), (wave, 1.1, 3.4)):
        for leg in (1, 2, 3):
            assert _ends(planned_swings(gait, period, leg, t_end)) == pytest.approx(
                _ends(_swings_by_sampling(gait, period, leg, t_end)), abs=2e-4), (period, leg)
    assert plan_of(summary(), "baseline") == (TRIPOD, 0.6) and plan_of(summary(), "other") == (None, None)


def test_page_shows_plan_beside_contact_in_the_run_colour():
    fig = views.gait_diagram(summary(), {"best": trace()})["figure"]
    by = {d["name"]: d for d in fig["data"]}
    color = views.RUNS["best"][1]
    swing, support, plan = by["recovered gait: swing (measured)"], by["recovered gait: support (measured)"], \
        by["recovered gait: planned swing"]
    assert swing["marker"]["color"] == color and support["marker"]["color"] == faded(color)
    assert faded(color).endswith(f",{GAIT_SCHEME['support_alpha']})") and plan["marker"]["color"] == GAIT_SCHEME["planned"]
    assert "recovered · leg 2" in plan["y"] and "recovered · leg 2" not in swing["y"]  # planned, never lifted
    assert plan["offset"] >= swing["offset"] + swing["width"]  # beside, not on top of each other


def test_bundle_png_uses_the_same_colours(tmp_path, monkeypatch):
    """At points of the PNG inside each bar (found from the figure's own axes), the measured
    swing is the run's colour, the measured support that colour at the page's support alpha
    over white, the planned swing the page's planned grey, and where nothing is planned the
    background shows: leg 1 swings in [0, 0.3) and is planned to; leg 2 stands throughout and
    is planned to swing in [0.3, 0.6)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figs = []
    real = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **kw: (figs.append(self), real(self, *a, **kw))[1])
    color = views.RUNS["best"][1]
    png = [p for p in plots.gait_diagram(trace(), tmp_path, color=color, plan=(TRIPOD, 0.6)) if p.suffix == ".png"][0]
    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    fig = figs[-1]
    fig.set_dpi(110)
    box = fig.get_tightbbox(FigureCanvasAgg(fig).get_renderer()).padded(0.1)  # what bbox_inches="tight" kept, in inches

    def at(t: float, y: float) -> np.ndarray:
        x_px, y_px = fig.axes[0].transData.transform((t, y))
        col, row = x_px - box.x0 * 110, box.y1 * 110 - y_px
        return img[int(round(row)), int(round(col))]

    def rgb(hex_color: str) -> np.ndarray:
        return np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])

    run, planned, white = rgb(color), rgb(GAIT_SCHEME["planned"]), np.array([255, 255, 255])
    support = GAIT_SCHEME["support_alpha"] * run + (1 - GAIT_SCHEME["support_alpha"]) * white
    measured, plan = -0.17, 0.27  # the middle of each bar, above its leg's tick
    expect = {(0.15, 1 + measured): run, (0.45, 1 + measured): support, (0.15, 1 + plan): planned,
              (0.45, 1 + plan): white, (0.15, 0 + measured): support, (0.45, 0 + measured): support,
              (0.15, 0 + plan): white, (0.45, 0 + plan): planned}
    for (t, y), want in expect.items():
        assert np.abs(at(t, y) - want).max() <= 3, (t, y, at(t, y), want)
