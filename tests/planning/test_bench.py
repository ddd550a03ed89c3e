"""The multigait benchmark the lead's `gaitmend bench` calls."""

from app.planning.bench import bench_multigait


def test_quick_bench_reports_the_figures():
    f = bench_multigait(quick=True)
    for key in ("rrt_cost_eval_s", "rrt_cost_eval_cpu_s", "multigait_paper_run_estimate_s",
                "multigait_paper_run_estimate_cpu_s", "multigait_generation_s"):
        assert f[key] > 0
    assert f["rrt_nodes_mean"] > 1
    # one cost evaluation with cached primitives: target <= 0.2 s (CPU time, robust to load)
    assert f["rrt_cost_eval_cpu_s"] < 0.2
    assert f["multigait_paper_run_estimate_s"] >= f["multigait_generation_s"]
