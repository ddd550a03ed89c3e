"""The Python client's adaptation sessions (issue 44; /api/adaptations): start a session
over finished repertoire jobs, post each measured trial, read the session, download a
proposed gait for the robot. Mixed into ``Client``; each call returns the API's JSON.

    s = client.create_adaptation([map_job_id], method="gaitmend")
    gait = s["next"]                           # the gait to run: map, elite, params, prediction
    s = client.post_trial(s["id"], 1, forward_m=0.31, lateral_m=-0.02, yaw_deg=4.0, fell=False,
                          duration_s=10.0)     # the session after it: s["next"], s["decision"]
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

JSON = {"Content-Type": "application/json"}


class AdaptationsMixin:
    def create_adaptation(self, repertoires: list[str], method: str = "ite", trial_s: float | None = None,
                          alpha: float | None = None, max_trials: int | None = None, name: str = "") -> dict:
        """A new session over the repertoire jobs (the first is ITE's map); its ``next`` is the
        first gait to run. ``alpha`` and ``max_trials``: the stop rule (default ITE's 0.9, 20)."""
        stop = {k: v for k, v in (("alpha", alpha), ("max_trials", max_trials)) if v is not None}
        body: dict[str, Any] = {"repertoires": list(repertoires), "method": method, "name": name, "stop": stop}
        if trial_s is not None:
            body["trial_s"] = trial_s
        return self.request("POST", "/api/adaptations", content=json.dumps(body, allow_nan=False),
                            headers=JSON).json()

    def adaptation(self, adaptation_id: str) -> dict:
        """The session: trials in order, the stop decision and why, the next gait (None once finished)."""
        return self.get_json(f"/api/adaptations/{adaptation_id}")

    def adaptations(self, limit: int = 50) -> list[dict]:
        return self.get_json("/api/adaptations", limit=limit)["items"]

    def post_trial(self, adaptation_id: str, trial: int, *, forward_m: float, lateral_m: float, yaw_deg: float,
                   fell: bool, duration_s: float, note: str = "") -> dict:
        """What the lab measured of trial ``trial`` (1 for the first; the gait the session
        proposed for it); returns the session after it. A repeat of a stored trial is a
        ``Conflict`` naming ``trial``; a bad number an ``InvalidSpec`` naming its field."""
        body = {"trial": trial, "forward_m": forward_m, "lateral_m": lateral_m, "yaw_deg": yaw_deg, "fell": fell,
                "duration_s": duration_s, "note": note}
        try:
            content = json.dumps(body, allow_nan=False)
        except ValueError:  # NaN or infinity: sent as the server would see them, so its error names the field
            content = json.dumps(body)
        return self.request("POST", f"/api/adaptations/{adaptation_id}/trials", content=content, headers=JSON).json()

    def adaptation_trials(self, adaptation_id: str) -> list[dict]:
        return self.get_json(f"/api/adaptations/{adaptation_id}/trials")["items"]

    def proposal_bundle(self, adaptation_id: str, trial: int, path: str | Path | None = None) -> Path:
        """The gait proposed for trial ``trial`` as a zip for the robot (setpoints.csv,
        gait.json, the controller module and its layout)."""
        path = Path(path or f"adaptation-{adaptation_id[:12]}-trial{trial}.zip")
        return self.download(f"/api/adaptations/{adaptation_id}/proposals/{trial}/bundle", path)
