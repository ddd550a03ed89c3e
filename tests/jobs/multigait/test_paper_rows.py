"""Issue 28's multigait rows and coverage scale: the row names map to the paper's maps,
costs and stuck modules, the coverage count at any cell size, and the node ceiling that
puts the paper's T- and L-shape values out of reach at 1 mu cells."""

from __future__ import annotations

import numpy as np
import pytest

from app.jobs.multigait.reproduce.paper_rows import RowsParams, _row_spec, ceiling, cell_coverage, not_attempted, plan
from app.jobs.multigait.spec import MultigaitSpec
from app.robots.modular import SHAPES


def test_ceiling_of_a_tree_of_k_max_iterations():
    assert ceiling(451, 1.0) == pytest.approx(100 * 451 / 1296)  # 34.8 %: below the paper's 42.5 and 52.1
    assert ceiling(451, 1.0) < 42.5 < 52.1
    assert ceiling(451, 1.25) > 52.1 and ceiling(451, 2.0) == 100.0


def test_cell_coverage_counts_cells_holding_a_node():
    pts = np.array([[0.1, 0.1], [0.9, 0.9], [1.1, 0.1], [47.9, 26.9]])
    assert cell_coverage(pts, 1.0) == pytest.approx(100 * 3 / 1296)  # the first two share a cell
    assert cell_coverage(pts, 2.0) == pytest.approx(100 * 2 / (24 * 14))


def test_rows_are_the_papers():
    p = RowsParams(robots="lizard,tshape", rows="E,E2,C1,dist-C", seeds="0,1")
    todo = plan(p)
    assert len(todo) == 2 * 4 * 2 and todo[0][0] == "lizard E seed 0" and todo[-1][0] == "tshape dist-C seed 1"
    s = _row_spec(p, "tshape", "E2", 0)
    assert s["damage"]["stuck_modules"] == list(SHAPES["tshape"].failures) and s["map"] == "empty"
    assert s["cost"] == "coverage" and not s["reuse"]["enabled"]
    s = _row_spec(p, "lizard", "dist-C", 3)
    assert s["map"] == "column" and s["cost"] == "distance" and s["search"]["seed"] == 3
    assert _row_spec(p, "lizard", "C1", 0)["damage"]["stuck_modules"] == [SHAPES["lizard"].failures[0]]
    assert _row_spec(p, "lizard", "E", 0)["reuse"]["enabled"]  # Tables III-IV come from the healthy Empty rows
    for _, spec, _ in todo:
        MultigaitSpec.parse(spec)  # every row is a valid job


def test_not_attempted_lists_what_the_data_lacks():
    text = not_attempted(None)
    assert "Not run yet (40 rows)" in text and "staircase" in text and "20 trials" in text


def test_paper_budget_hours_scale_by_evaluations_from_the_rows():
    """The paper-budget estimate comes from the data's rows: 48 evaluations in 24 s is 0.5 s
    an evaluation, so a 3020-evaluation run is about 25 min and 800 of them 336 h."""
    from app.jobs.multigait.reproduce.paper_rows import _paper_budget_hours

    runs = [{"spec": {"search": {"particles": 8, "generations": 5}}, "wall_s": w} for w in (20.0, 28.0)]
    text = _paper_budget_hours(runs)
    assert "about 25 min a run and 336 h in all" in text and "0.50 s of wall time an evaluation" in text
    assert _paper_budget_hours([]) == ""
