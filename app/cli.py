"""The ``gaitmend`` command line."""

from __future__ import annotations

import hashlib
import json
import sys
import time
import zipfile
from importlib import resources
from pathlib import Path
from typing import Any, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from app.jobs.base import SpecError, dumps
from app.jobs.registry import get_kind, parse_spec

cli = typer.Typer(add_completion=False, no_args_is_help=True, help="Gait recovery for damaged legged robots.")
err = Console(stderr=True)


def fail(msg: str, code: int = 2) -> None:
    err.print(f"[bold red]error:[/] {msg}", highlight=False)
    raise typer.Exit(code)


def load_spec(path: Optional[Path]):
    """Parse a spec file (spec JSON, bundle manifest or bundle zip); exit 2 if it is bad."""
    from app.bundle import read_spec_file

    try:
        if path is None:
            data = json.loads(resources.files("app.jobs").joinpath("default_spec.json").read_text())
        else:
            data = read_spec_file(path)
    except FileNotFoundError:
        fail(f"spec file not found: {path}")
    except (json.JSONDecodeError, zipfile.BadZipFile, KeyError, UnicodeDecodeError) as e:
        fail(f"cannot read spec {path}: {e}")
    try:
        return parse_spec(data)
    except SpecError as e:
        for item in e.errors:
            err.print(f"[bold red]error:[/] {item['field']}: {item['message']}", highlight=False)
        raise typer.Exit(2) from None


def progress_text(info: dict[str, Any]) -> str:
    """One line for a progress bar from a kind's progress info: searches report their
    best F, throughput and evaluations; other kinds show their own scalar fields."""
    if "best" in info:
        parts = [f"best F {info['best']:.4f}"]
        if "sim_steps_per_s" in info:
            parts.append(f"{info['sim_steps_per_s'] / 1e3:.0f}k steps/s")
        if "evaluations" in info:
            parts.append(f"{info['evaluations']} evals")
        return "  ".join(parts)
    return "  ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                     for k, v in info.items() if isinstance(v, (int, float, str, bool)))[:80]


class LocalContext:
    """Run context for `gaitmend run`: a progress bar, checkpoints kept in memory."""

    def __init__(self, artifact_dir: Path, progress: Progress | None, task=None):
        self.artifact_dir = artifact_dir
        self._progress, self._task = progress, task
        self._ckpt: dict | None = None

    def progress(self, done: int, total: int, info: dict[str, Any]) -> None:
        if self._progress is not None:
            self._progress.update(self._task, completed=done, total=total, info=progress_text(info))

    def save_checkpoint(self, state: dict) -> None:
        self._ckpt = state

    def load_checkpoint(self) -> dict | None:
        return self._ckpt

    def is_cancelled(self) -> bool:
        return False


def local_job_id(spec) -> str:
    h = hashlib.sha256(spec.model_dump_json().encode()).hexdigest()[:8]
    return f"local-{time.strftime('%Y%m%d-%H%M%S')}-{h}"


@cli.command()
def run(
    spec_path: Optional[Path] = typer.Argument(None, metavar="[SPEC]",
                                               help="spec JSON, a bundle's manifest.json or bundle zip; default: the embedded paper scenario (legs 1 and 6 lost)"),
    out: Path = typer.Option(Path("results"), "--out", help="folder for the result bundle"),
    as_json: bool = typer.Option(False, "--json", help="print the summary as one JSON object on the last stdout line"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Run one job locally, with no server, and write its result bundle."""
    from app.bundle import write_bundle

    spec = load_spec(spec_path)
    kind = get_kind(spec.kind)
    job_id = local_job_id(spec)
    progress = None if quiet else Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"), TimeElapsedColumn(), console=err, transient=False)
    with (progress or _nullcontext()):
        task = progress.add_task(spec.kind, total=None, info="") if progress else None
        result = kind.run(spec, LocalContext(out, progress, task))
    bundle = write_bundle(out / f"{job_id}.zip", job_id, spec, result)
    with zipfile.ZipFile(bundle) as z:
        z.extractall(out)
    s = result.summary
    if as_json:
        print(dumps(s | {"job_id": job_id, "bundle": str(bundle)}))
    else:
        _print_summary(s, bundle)


class _nullcontext:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False


def _print_summary(s: dict, bundle: Path) -> None:
    from rich.table import Table

    con = Console()
    if s.get("kind") == "recovery":
        t = Table(title=f"{s['robot']}: legs {s['damage']['lost_legs']} lost, gait {s['gait']['name']} (sigma={s['gait']['sigma']})")
        for c in ("", "x (cm)", "y (cm)", "yaw (deg)", "roll amp (deg)", "pitch amp (deg)", "fell", "F"):
            t.add_column(c)
        for name in ("baseline", "best"):
            m = s[name]["metrics"]
            t.add_row("before (nominal tripod)" if name == "baseline" else "after recovery",
                      f"{100 * m['x_f_m']:.1f}", f"{100 * m['y_f_m']:.1f}", f"{m['yaw_f_deg']:.1f}",
                      f"{m['roll_amp_deg']:.2f}", f"{m['pitch_amp_deg']:.2f}", str(m["fell"]), f"{s[name]['fitness']:.4f}")
        con.print(t)
    elif s.get("kind") == "tipping":
        t = Table(title=f"{s['robot']}: {s['scenario']['type']} scenario, threshold {s['threshold_deg']} deg")
        for c in ("run", "tipped (s)", "below threshold (s)", "detected (s)", "edge", "leg", "adjust (s)",
                  "margin before/after (deg)", "final tilt (deg)"):
            t.add_column(c)
        for name, r in s.get("runs", {}).items():
            def f(k, fmt="{:.2f}"):
                v = r.get(k)
                return "-" if v is None else fmt.format(v) if isinstance(v, float) else str(v)
            margins = "-" if r.get("margin_before_landing_deg") is None else \
                f"{r['margin_before_landing_deg']:.1f} / {r['margin_after_landing_deg']:.1f}"
            t.add_row(name, f("tipped_at_s") if r.get("tipped") else "no", f("first_below_threshold_s"),
                      f("detection_time_s"), f("tipping_edge"), f("adjustment_leg"), f("adjustment_time_s"),
                      margins, f("final_body_tilt_deg", "{:.1f}"))
        con.print(t)
        if s.get("sweep"):
            con.print(s["sweep"] if isinstance(s["sweep"], str) else json.dumps(s["sweep"])[:2000])
    elif s.get("kind") == "multigait":
        r = s["result"]
        stuck = s["damage"].get("stuck_modules") or "none"
        t = Table(title=f"{s['robot']}: {s['gaits']} gaits, cost {s['cost']} ({s['cost_units']}), stuck modules {stuck}")
        for c in ("", "first generation best", "first generation mean", "final best", "final mean"):
            t.add_column(c)

        def g(v):
            return "-" if v is None else f"{v:.2f}"
        t.add_row(s["cost"], g(r["initial_best"]), g(r["initial_mean"]), g(r["final_best"]), g(r["final_mean"]))
        con.print(t)
        con.print(f"best tree: {r['tree_nodes']} nodes, {r['goal_distance_mu']:.2f} mu from the goal; "
                  f"re-planned cost matches the search: {r['reproduced']}")
        for name, sc in (s.get("reuse") or {}).items():
            con.print(f"reuse {name}: distance {sc['distance_mu']['mean']:.2f} ({sc['distance_mu']['std']:.2f}) mu, "
                      f"coverage {sc['coverage_pct']['mean']:.1f} ({sc['coverage_pct']['std']:.1f}) %")
    tm = s["timing"]
    parts = [f"{tm['wall_s']:.1f} s"]
    if "evaluations" in tm:
        parts.insert(0, f"{tm['evaluations']} evaluations in")
    if tm.get("sim_steps_per_s"):
        parts.append(f"({tm['sim_steps_per_s'] / 1e3:.1f}k sim steps/s)")
    con.print(" ".join(parts) + f"; bundle: {bundle}")


@cli.command()
def bench(
    as_json: bool = typer.Option(False, "--json", help="print the figures as one JSON object on the last stdout line"),
    quick: bool = typer.Option(False, "--quick", help="small budget (CI smoke); figures are not the targets'"),
):
    """Measure rollout and evaluator throughput, a paper-size recovery and scipy's DE as a peer."""
    from app.bench import run_bench

    figures = run_bench(quick=quick, log=err.print)
    if as_json:
        print(json.dumps(figures))
    else:
        for k, v in figures.items():
            Console().print(f"{k:28s} {v}")


@cli.command()
def reproduce(
    seeds: int = typer.Option(10, min=1, max=100, help="seeds per scenario"),
    out: Path = typer.Option(Path("docs/table2.md"), "--out", help="markdown table to write"),
    generations: int = typer.Option(60, min=1, help="DE generations (paper: 60)"),
    population: int = typer.Option(30, min=4, help="DE population (paper: 30)"),
):
    """Run paper 000's Table II scenarios (legs 1&6, 3&4, 1, 4 lost) over seeds; write the table."""
    from app.reproduce import run_table2

    md = run_table2(seeds=seeds, generations=generations, population=population, log=err.print)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(md)
    print(md)


from app import service_cli  # noqa: E402,F401  (serve, worker, submit, jobs, fetch, db, token)


@cli.command()
def replay(
    target: str = typer.Argument(..., help="a bundle (.zip or unpacked folder) or a job id on --server"),
    host: str = typer.Option("127.0.0.1", help="address the viser server binds"),
    port: int = typer.Option(8081, min=1, max=65535),
    server: str = typer.Option("http://127.0.0.1:8000", "--server", envvar="GAITMEND_SERVER",
                               help="API to fetch the bundle of a job id from"),
    token: Optional[str] = typer.Option(None, envvar="GAITMEND_TOKEN", help="API token for --server"),
):
    """Open a live 3D replay (timeline, play/pause, speed, recovered/baseline toggle)."""
    import io

    import mujoco
    import numpy as np

    from app.replay import serve_live

    path = Path(target)
    try:
        if path.is_dir():
            files = {p.relative_to(path).as_posix(): p.read_bytes() for p in path.rglob("*") if p.is_file()}
        else:
            if path.is_file():
                blob = path.read_bytes()
            else:
                import urllib.request

                req = urllib.request.Request(f"{server.rstrip('/')}/api/jobs/{target}/bundle")
                if token:
                    req.add_header("Authorization", f"Bearer {token}")
                with urllib.request.urlopen(req, timeout=60) as r:
                    blob = r.read()
            with zipfile.ZipFile(io.BytesIO(blob)) as z:
                files = {n: z.read(n) for n in z.namelist()}
    except (OSError, zipfile.BadZipFile) as e:
        fail(f"cannot load bundle {target!r}: {e}")
    if "robot.xml" not in files:
        fail(f"{target!r} is not a gaitmend bundle (no robot.xml)")
    model = mujoco.MjModel.from_xml_string(files["robot.xml"].decode())
    traces = {}
    for name, data in sorted(files.items()):
        if name.startswith("trajectories/") and name.endswith(".npz"):
            tr = dict(np.load(io.BytesIO(data)))
            if "qpos" in tr:
                traces[name[len("trajectories/"):-4]] = tr
    if not traces:
        fail(f"{target!r} has no replayable trajectories")
    traces = dict(sorted(traces.items(), key=lambda kv: (kv[0] != "best", kv[0])))  # recovered gait first
    err.print(f"replay of {', '.join(traces)} on http://{host}:{port} (Ctrl-C to stop)")
    serve_live(model, traces, host=host, port=port)


def main() -> None:
    try:
        cli()
    except KeyboardInterrupt:
        sys.exit(130)


if __name__ == "__main__":
    main()
