"""A session's page plots (app/api/routes/adaptations.py): the map the method proposes
from, coloured by its prior (what the map predicted before any trial) and by the posterior
after the trials so far, as a 2-D projection of the behaviour descriptor (the two axes of a
2-D descriptor; otherwise its first two principal components), with the tried gaits
numbered and the next one starred. Plotly figure dicts, as the kinds' views are."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from app.adapt import methods as M
from app.adapt.maps import Repertoire
from app.jobs import viewkit as vk

MAX_POINTS = 5000  # the page draws at most this many elites (the best by prior), as the repertoire page


def project(x: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[str]]:
    """(N, 2) coordinates and their axis titles."""
    if x.shape[1] <= 2:
        return np.pad(x, ((0, 0), (0, 2 - x.shape[1]))), [*names, ""][:2]
    c = x - x.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    vt = vt[:2] * np.sign(vt[:2, :1] + 1e-12)  # a fixed sign: the same map always looks the same
    return c @ vt.T, ["principal component 1", "principal component 2"]


def map_panels(reps: Sequence[Repertoire], spec, trials, step) -> list[dict]:
    from app.adapt.session import settings_of

    s = settings_of(spec)
    ts = [t.trial() for t in trials]
    posts, _ = M._posteriors([r.map for r in reps], ts, s)  # the posterior the method itself proposes from
    name = step.proposal.map if step.proposal is not None else next(iter(posts))
    m, prior, post = posts[name]
    rep = next(r for r in reps if r.map.name == name)
    xy, titles = project(np.asarray(m.descriptors, float), list(rep.descriptor))
    keep = np.argsort(prior, kind="stable")[-MAX_POINTS:]
    lo, hi = float(min(prior.min(), post.mean.min())), float(max(prior.max(), post.mean.max()))
    tried = [k for k, t in enumerate(trials) if t.map == name]
    out = []
    for pid, title, values in (("prior", "The map: prior (m/s)", prior), ("posterior", "After the trials: posterior "
                                                                                      "mean (m/s)", post.mean)):
        data = [{"type": "scattergl", "mode": "markers", "x": vk.series(xy[keep, 0]), "y": vk.series(xy[keep, 1]),
                 "marker": {"color": vk.series(values[keep]), "colorscale": "Viridis", "cmin": lo, "cmax": hi,
                            "size": 5, "showscale": True, "colorbar": {"title": {"text": "m/s"}}},
                 "name": "elites", "hovertemplate": "%{marker.color:.3f} m/s<extra></extra>"}]
        if tried:
            e = [trials[k].elite for k in tried]
            data.append({"type": "scatter", "mode": "markers+text", "x": vk.series(xy[e, 0]), "y": vk.series(xy[e, 1]),
                         "text": [str(trials[k].index) for k in tried], "textposition": "top center",
                         "marker": {"color": "#d62728", "size": 9, "symbol": "x"}, "name": "tried"})
        if step.proposal is not None:
            i = step.proposal.elite
            data.append({"type": "scatter", "mode": "markers", "x": vk.series(xy[[i], 0]), "y": vk.series(xy[[i], 1]),
                         "marker": {"color": "#ff7f0e", "size": 16, "symbol": "star",
                                    "line": {"color": "#000", "width": 1}}, "name": "next"})
        layout = {"height": 340, "margin": {"t": 20, "l": 50, "r": 10, "b": 45}, "showlegend": False,
                  "xaxis": vk.axis(titles[0]), "yaxis": vk.axis(titles[1])}
        cap = (f"map \"{name}\", {len(m.descriptors)} elites ({min(len(keep), len(m.descriptors))} drawn); "
               f"x: tried (numbered), star: the next gait")
        out.append(vk.panel(pid, title, cap, figure=vk.figure(data, layout)))
    return out
