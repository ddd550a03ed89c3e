"""`gaitmend adapt`: adapt a damaged robot's gait with one or more repertoires (app/adapt).
With ``--simulate REALITY.json`` the trials are played on a simulated reality (a robot, a
damage and a perturbed world the method never sees) until the method stops; without it,
each proposed gait is printed and its measurement is read from stdin, one line a trial
(app/adapt/lab.py), as a lab running the robot would type it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from app.cli.common import cli, fail, fail_fields
from app.jobs.base import SpecError

METHODS = ("ite", "gaitmend")  # app/adapt/methods.py ITE and GAITMEND


def _reality(path: Path):
    from app.adapt.reality import Reality
    from app.api.body import BodyError, parse_json

    try:
        data = parse_json(path.read_bytes())  # the API's parser: NaN, duplicate keys, a BOM are errors
    except FileNotFoundError:
        fail(f"--simulate: reality file not found: {path}")
    except IsADirectoryError:
        fail(f"--simulate: {path} is a folder; give a reality JSON")
    except BodyError as e:
        fail_fields(e.errors, f"{path}: ")
    from app.cli.robot import load_local_robot

    try:
        return Reality.parse(data, robots=load_local_robot)  # an uploaded robot: one stored here
    except SpecError as e:
        fail_fields(e.errors, f"{path}: ")


@cli.command()
def adapt(
    maps: list[Path] = typer.Argument(None, metavar="BUNDLE_OR_RESULT...", help=(
        "repertoire results: a bundle zip, its folder or manifest.json, or a result JSON; the first is ITE's map "
        "(with --server: repertoire job ids on the server)"), show_default=False),
    simulate: Optional[Path] = typer.Option(None, "--simulate", metavar="REALITY.json", help=(
        "play the trials on a simulated reality: {\"robot\" (built-in, or an id of `gaitmend robot list`), "
        "\"damage\", \"perturbation\"} (docs/adapt.md); "
        "without it, each measurement is read from stdin: forward_m lateral_m yaw_deg fell duration_s")),
    method: Optional[str] = typer.Option(None, "--method", help="ite (Cully et al. 2015, one map; the default) or "
                                                                 "gaitmend (several maps, straight, falls count 0)"),
    as_json: bool = typer.Option(False, "--json", help="the outcome as one JSON object on the last stdout line"),
    server: Optional[str] = typer.Option(None, "--server", help=(
        "run the session on this API (its dashboard page shows it): the arguments are repertoire job ids there")),
    session: Optional[str] = typer.Option(None, "--session", help=(
        "go on with this open session on the server (--server, or GAITMEND_SERVER); no arguments")),
    token: Optional[str] = typer.Option(None, "--token", help="API token for the server (default GAITMEND_TOKEN)"),
    alpha: Optional[float] = typer.Option(None, "--alpha", help="new server sessions: stop when the best measured "
                                                                 "reaches alpha x the best prediction (default 0.9)"),
    max_trials: Optional[int] = typer.Option(None, "--max-trials", help="new server sessions: at most this many "
                                                                          "trials (default 20)"),
    bundles: Optional[Path] = typer.Option(None, "--bundles", metavar="DIR", help=(
        "server sessions: save each proposed gait for the robot (set-points, controller) as DIR/trialN.zip")),
):
    """Adapt: propose a gait from the maps, play it, post the measurement, until the method stops."""
    if method is not None and method not in METHODS:
        fail(f"--method: unknown method {method!r}; allowed: {', '.join(METHODS)}")
    if server is not None or session is not None:
        if simulate is not None:
            fail("--simulate plays a local loop over bundles; it does not go with --server or --session")
        from app.cli.adapt_server import adapt_on_server

        adapt_on_server([str(m) for m in maps or []], server, session, token, method, alpha, max_trials, bundles, as_json)
        return
    if alpha is not None or max_trials is not None or bundles is not None:
        fail("--alpha, --max-trials and --bundles are for sessions on a server (--server); "
             "a local loop uses the method's published stop rule")
    from app.adapt import methods as M
    from app.adapt.maps import MapError, read_repertoires
    from app.adapt.simulate import adapt as run_adapt
    from app.adapt.simulate import run as run_loop

    method = method or "ite"
    if not maps:
        fail("BUNDLE_OR_RESULT: give at least one repertoire (a bundle, its folder or a result JSON)")
    reality = _reality(simulate) if simulate is not None else None
    try:
        reps = read_repertoires(maps)
    except MapError as e:
        fail(f"BUNDLE_OR_RESULT: {e}")
    settings = M.ITE if method == "ite" else M.GAITMEND
    header = (f"{'trial':>5}  {'map':<24} {'elite':>5} {'cell':>5} {'pred_m/s':>9}  {'forward_m':>9} {'lateral_m':>9} "
              f"{'yaw_deg':>8} {'fell':>5}  {'m/s':>7} recovered")
    print(header, flush=True)

    def show(r) -> None:
        m = r.measured
        rec = "-" if r.recovered is None else ("yes" if r.recovered else "no")
        print(f"{r.trial:>5}  {r.proposal.map[:24]:<24} {r.proposal.elite:>5} {r.cell:>5} {r.proposal.predicted:>9.4f}  "
              f"{m.forward_m:>9.4f} {m.lateral_m:>9.4f} {m.yaw_deg:>8.2f} {str(m.fell).lower():>5}  "
              f"{m.forward_m / m.duration_s:>7.4f} {rec}", flush=True)

    try:
        if reality is not None:
            out = run_adapt(reps, reality, settings, show)
        else:
            out = run_loop(reps, _typed_in, settings, reps[0].robot, show)
    except (ValueError, SpecError) as e:  # a map that does not fit the reality's robot
        fail(f"--simulate: {e}" if reality is not None else str(e))
    target = f">= {out.target_m_s:.3f} m/s, no fall" if out.target_m_s is not None else "no target for this robot"
    print(f"stop: {out.decision.reason}; recovered ({target}) at trial "
          f"{out.recovered_at if out.recovered_at is not None else 'none'}", flush=True)
    if as_json:
        print(json.dumps(out.to_json(method)), flush=True)
    if not out.decision.stop:
        raise typer.Exit(1)  # the measurements ended before the method stopped


def _typed_in(rep, p):
    """One trial run by hand: the gait to run, then its measurement from stdin (None at the
    end of input)."""
    x = [float(v) for v in rep.params[p.elite]]
    print(f"run: map {p.map!r} elite {p.elite} (cell {rep.cells[p.elite]}), predicted {p.predicted:.4f} m/s; "
          f"gait x = {json.dumps(x)}", flush=True)
    from app.cli.measured import read_measurement

    return read_measurement(f"elite {p.elite}")
