"""`gaitmend adapt --server`: an adaptation session held by the API (issue 44), so that its
dashboard page shows every trial as the lab posts it and it survives the laptop at the
robot: each proposed gait is printed (and with ``--bundles`` saved for the robot as
set-points and the controller), the lab types what it measured (app/adapt/lab.py), the
measurement is posted and the server's answer gives the next gait and the stop decision.
``--session ID`` goes on with an open session, from its next trial."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from app.cli.measured import read_measurement
from app.cli.client import _client
from app.cli.common import fail


def adapt_on_server(jobs: list[str], server: Optional[str], session: Optional[str], token: Optional[str],
                    method: Optional[str], alpha: Optional[float], max_trials: Optional[int],
                    bundles: Optional[Path], as_json: bool) -> None:
    if session is not None and (jobs or method is not None or alpha is not None or max_trials is not None):
        fail("--session: the session keeps its own maps, method and stop rule; give no repertoire ids, "
             "--method, --alpha or --max-trials")
    if session is None and not jobs:
        fail("BUNDLE_OR_RESULT: give the repertoire job ids on the server (the first is ITE's map), or --session")
    if bundles is not None:
        if bundles.exists() and not bundles.is_dir():
            fail(f"--bundles: {bundles} is a file; give a folder")
        bundles.mkdir(parents=True, exist_ok=True)
    with _client(server, token) as c:
        if session is None:
            s = c.create_adaptation(jobs, method=method or "ite", alpha=alpha, max_trials=max_trials)
        else:
            s = c.adaptation(session)
        print(f"session {s['id']} ({s['method']}): {c.server.rstrip('/')}{s['links']['page']}", flush=True)
        for t in s["trials"]:
            _show(t)
        while s["next"] is not None:
            p = s["next"]
            n = p["trial"]
            print(f"run trial {n}: map {p['map']!r} elite {p['elite']} (cell {p['cell']}) for {p['trial_s']:g} s, "
                  f"predicted {p['predicted_m_s']:.4f} m/s ({p['predicted_forward_m']:.3f} m); "
                  f"gait x = {json.dumps(p['params'])}", flush=True)
            if bundles is not None:
                print(f"  for the robot: {c.proposal_bundle(s['id'], n, bundles / f'trial{n}.zip')}", flush=True)
            m = read_measurement(f"trial {n}")
            if m is None:
                break
            s = c.post_trial(s["id"], n, forward_m=m.forward_m, lateral_m=m.lateral_m, yaw_deg=m.yaw_deg,
                             fell=m.fell, duration_s=m.duration_s)
            _show(s["trials"][-1])
    d = s["decision"]
    recovered_at = next((t["trial"] for t in s["trials"] if t["recovered"]), None)
    ended = s["next"] is not None
    why = (f"measurements ended after {len(s['trials'])} trials, before the method stopped ({d['reason']})"
           if ended else d["reason"])
    print(f"stop: {why}; recovered at trial {recovered_at if recovered_at is not None else 'none'}; "
          f"session {s['id']} is {s['status']}", flush=True)
    if as_json:
        print(json.dumps({"session": s["id"], "method": s["method"], "status": s["status"], "trials": s["trials"],
                          "recovered_at": recovered_at, "target_m_s": s["target_m_s"], "decision": d}), flush=True)
    if ended:
        raise typer.Exit(1)  # the measurements ended before the method stopped


def _show(t: dict) -> None:
    rec = "-" if t["recovered"] is None else ("yes" if t["recovered"] else "no")
    pred = t["predicted_m_s"]
    print(f"trial {t['trial']}: forward {t['forward_m']:.4f} m, lateral {t['lateral_m']:.4f} m, yaw {t['yaw_deg']:.2f} deg, "
          f"fell {str(t['fell']).lower()}, {t['speed_m_s']:.4f} m/s (predicted {'-' if pred is None else f'{pred:.4f}'}); "
          f"recovered {rec}", flush=True)
