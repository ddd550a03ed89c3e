"""``Job`` and ``Study``: what ``Client`` returns. Each holds the API's last answer and
asks again when told to (``refresh``, ``wait``) or when a finished result is first read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

FINAL = ("succeeded", "failed", "cancelled")


class Job:
    """A job on the server. ``info`` is the API's JobOut (a dict); ``id``, ``kind``,
    ``status``, ``summary`` ... read it. ``history`` and ``headline`` are DataFrames."""

    def __init__(self, client, info: dict):
        self.client, self.info = client, info

    def __repr__(self) -> str:
        p = self.info.get("progress") or {}
        return f"<gaitmend.Job {self.id[:8]} {self.kind} {self.status} {p.get('done', 0)}/{p.get('total', 0)}>"

    def __getattr__(self, name: str) -> Any:
        info = self.__dict__.get("info") or {}
        if name in info:
            return info[name]
        raise AttributeError(name)

    @property
    def id(self) -> str:
        return self.info["id"]

    @property
    def status(self) -> str:
        return self.info["status"]

    @property
    def done(self) -> bool:
        return self.status in FINAL

    def refresh(self) -> Job:
        self.info = self.client.get_json(f"/api/jobs/{self.id}")
        return self

    def wait(self, progress: bool = True, timeout: float | None = None, interval: float = 0.5,
             raise_on_failure: bool = False) -> Job:
        """Poll until the job is succeeded, failed or cancelled (a progress bar in a
        notebook or a terminal with ``progress``); returns the job. ``raise_on_failure``:
        a failed or cancelled job raises RuntimeError with its error."""
        from app.client.progress import bar

        with bar(progress, self.id[:8]) as show:
            self.info = self.client.poll(f"/api/jobs/{self.id}", lambda j: j["status"] in FINAL,
                                         lambda j: show(j["progress"]["done"], j["progress"]["total"],
                                                        j["status"] + (f"  {j['progress'].get('text') or ''}")),
                                         timeout=timeout, interval=interval)
        if raise_on_failure and self.status != "succeeded":
            raise RuntimeError(f"job {self.id} {self.status}: {self.info.get('error') or 'no reason recorded'}")
        return self

    def _finished(self) -> dict:
        if self.info.get("summary") is None or self.status not in FINAL:
            self.refresh()
        return self.info

    @property
    def summary(self) -> dict | None:
        """result.json: the kind's summary, once succeeded (else None)."""
        return self._finished().get("summary")

    @property
    def verdict(self) -> dict | None:
        """Did the method work, in brief, once succeeded (else None): ``sentence`` (a fragile
        gait's first words say so), ``target_met``, ``controls``, ``held_out`` (the held-out
        random models: ``met`` of ``n`` keep the target, ``fell``, ``interval``, ``fragile``,
        ``text``; None without a held-out set), ``robustness`` [met, total] of the re-runs."""
        return self._finished().get("verdict")

    def summarise(self) -> str:
        """The verdict's sentence, as the job page and `gaitmend run` print it."""
        v = self.verdict
        return v["sentence"] if v else f"job {self.id} {self.status}: no verdict"

    @property
    def spec(self) -> dict:
        return self.info.get("spec") or self.refresh().info["spec"]

    @property
    def headline(self):
        """The numbers a user came for: label, value, unit, better, target, met."""
        import pandas as pd

        return pd.DataFrame(self._finished().get("headline") or [],
                            columns=["label", "value", "unit", "better", "target", "met"])

    @property
    def history(self):
        """One row per generation (or run, per the kind), as the job's history.csv."""
        from app.client.tables import frame

        return frame(self.client.get_json(f"/api/jobs/{self.id}/history"))

    def archive(self):
        """A repertoire job's map, one row per elite (app/client/repertoire.py)."""
        from app.client.repertoire import job_archive

        return job_archive(self)

    def bundle(self, path: str | Path | None = None) -> Path:
        """Download the result bundle; ``path`` a folder (default ".") or a .zip file name."""
        path = Path(path) if path is not None else Path(".")
        target = path if path.suffix == ".zip" else path / f"gaitmend-{self.id}.zip"
        return self.client.download(f"/api/jobs/{self.id}/bundle", target)

    def open_bundle(self, path: str | Path | None = None):
        """Download the bundle (see ``bundle``) and open it (``gaitmend.open_bundle``)."""
        from app.client.bundle_reader import open_bundle

        return open_bundle(self.bundle(path))

    def video(self, path: str | Path = "walk.mp4") -> Path:
        """The job's MP4 (recovered gait and baseline side by side), rendered by the server
        on the first request and kept with the bundle."""
        return self.client.download(f"/api/jobs/{self.id}/video", Path(path))

    def cancel(self) -> Job:
        self.info = self.client.cancel(self.id)
        return self

    def retry(self) -> Job:
        self.info = self.client.retry(self.id)
        return self

    def delete(self) -> None:
        self.client.delete(self.id)


class Study:
    """A study on the server: ``info`` is the API's study (with its points once fetched)."""

    def __init__(self, client, info: dict):
        self.client, self.info = client, info

    def __repr__(self) -> str:
        p = self.info.get("progress") or {}
        return f"<gaitmend.Study {self.id[:8]} {self.info.get('name')!r} {self.status} {p}>"

    @property
    def id(self) -> str:
        return self.info["id"]

    @property
    def status(self) -> str:
        return self.info["status"]

    def refresh(self) -> Study:
        self.info = self.client.get_json(f"/api/studies/{self.id}")
        return self

    def wait(self, progress: bool = True, timeout: float | None = None, interval: float = 1.0) -> Study:
        """Poll until every point is finished (a progress bar of points done)."""
        from app.client.progress import bar

        def update(s: dict) -> None:
            p = s.get("progress") or {}
            finished = p.get("done", 0) + p.get("failed", 0) + p.get("cancelled", 0)
            show(finished, p.get("points", 0), f"{p.get('running', 0)} running, {p.get('queued', 0)} queued"
                 if s["status"] not in FINAL else s["status"])

        with bar(progress, self.id[:8]) as show:
            self.info = self.client.poll(f"/api/studies/{self.id}", lambda s: s["status"] in FINAL,
                                         update, timeout=timeout, interval=interval)
        return self

    def jobs(self) -> list[Job]:
        """The points' jobs, in point order."""
        rows = self.info.get("jobs") or self.refresh().info.get("jobs") or []
        return [self.client.job(r["id"]) for r in rows if r.get("id")]

    def results(self):
        """One row per point: its index, job id and status, one column per overridden value
        (the grid's or the list's paths), one per reported metric (the study's
        ``report.metrics``, dotted paths into each point's summary) and the verdict's
        (``held_out_kept``, ``held_out_n``, ``held_out_share``, ``held_out_fell``,
        ``fragile``, ``verdict``: the job page's sentence)."""
        from app.client.tables import study_frame

        return study_frame(self.client.request("GET", f"/api/studies/{self.id}/bundle").content)

    def aggregate(self):
        """The study's aggregate (median and range of each metric per group), as a DataFrame."""
        import io
        import zipfile

        import pandas as pd

        data = self.client.request("GET", f"/api/studies/{self.id}/bundle").content
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return pd.read_csv(io.BytesIO(z.read("aggregate.csv")))

    def bundle(self, path: str | Path = ".") -> Path:
        path = Path(path)
        target = path if path.suffix == ".zip" else path / f"study-{self.id}.zip"
        return self.client.download(f"/api/studies/{self.id}/bundle", target)

    def cancel(self) -> Study:
        self.info = self.client.request("POST", f"/api/studies/{self.id}/cancel").json()
        return self
