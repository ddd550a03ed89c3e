"""Generations to converge (paper 000's "almost 30 generations", app/jobs/recovery/reproduce/curves.py),
counted from rows' best-F curves: fixture curves whose answers are known by hand."""
from app.jobs.recovery.reproduce import curves


def _curve(bests):
    return [[g, b, 30 * (g + 1)] for g, b in enumerate(bests)]


def _row(lost, bests):
    return {"lost_legs": list(lost), "generations": len(bests) - 1, "curve": _curve(bests)}


def test_generations_to_a_share_of_the_final_f():
    c = _curve([1.0, 5.0, 9.0, 9.5, 9.9, 10.0])
    assert curves.reached(c, 0.95) == 3 and curves.reached(c, 0.99) == 4 and curves.reached(c, 0.5) == 1


def test_the_table_counts_each_damage_and_runs_improving_after_generation_30():
    early = [1.0] * 5 + [10.0] * 56  # 60 generations, final from generation 5
    late = [1.0] * 40 + [20.0] * 21  # jumps at generation 40: after the paper's 30
    rows = [_row((1, 6), early), _row((1, 6), late), _row((4,), early), {"lost_legs": [4], "generations": 60}]
    body = curves.generation_rows(rows)
    assert body[1] == ["legs 1 & 6", 2, "22 [5, 40]", "22 [5, 40]", "52 [5, 100]", "1/2"]
    assert body[0] == ["leg 4", 1, "5 [5, 5]", "5 [5, 5]", "100 [100, 100]", "0/1"]  # the row without a curve: not counted
    md = curves.render_generations(rows, "docs/table2.json", "cmd")
    assert "almost 30 generations" in md and "| legs 1 & 6 | 2 |" in md


def test_rows_without_curves_say_so():
    assert "None of the 1 runs" in curves.render_generations([{"lost_legs": [1], "generations": 60}], "f.json", "c")
    assert "No data yet" in curves.render_generations([], "f.json", "c")
