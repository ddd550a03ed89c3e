"""Layout of the minefield panel (Fig. 9) found on screenshots of a real job page (issue 25):
the y range cut the zone discs at the top and bottom, and the legend below the plot sat on the
x axis title on a phone."""

from app.jobs.freegait.views import minefield_view


def _summary():
    feet = [{"x": 0.1 * i, "y": 0.12 * (-1) ** i, "leg": i % 6 + 1, "t": 0.5 * i, "in_zone": i == 3} for i in range(6)]
    # zones near the footholds: one 0.42 m above, one 0.45 m below (outside the footholds' +-0.3 m)
    zones = [[0.1, 0.54], [0.3, -0.57], [0.0, 0.0], [5.0, 5.0]]
    return {"footholds_list": feet, "zones": zones, "field": {"zone_radius_m": 0.025, "safe_radius_m": 0.075}}


def test_the_ranges_hold_every_zone_disc_drawn():
    lay = minefield_view(_summary(), {})["figure"]["layout"]
    (x0, x1), (y0, y1) = lay["xaxis"]["range"], lay["yaxis"]["range"]
    discs = [d for d in lay["shapes"] if d["type"] == "circle"]
    assert len(discs) == 6  # three zones near the walk, each a safe area and a forbidden disc; the far one is left out
    for d in discs:
        assert x0 <= d["x0"] and d["x1"] <= x1 and y0 <= d["y0"] and d["y1"] <= y1, (d, lay["yaxis"]["range"])


def test_the_legend_sits_above_the_plot_and_the_axes_keep_one_scale():
    lay = minefield_view(_summary(), {})["figure"]["layout"]
    assert lay["legend"]["y"] >= 1 and lay["legend"]["yanchor"] == "bottom"
    assert lay["yaxis"]["scaleanchor"] == "x" and lay["xaxis"]["constrain"] == "domain"
    assert lay["xaxis"]["automargin"] and lay["yaxis"]["automargin"]
