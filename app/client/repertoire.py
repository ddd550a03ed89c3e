"""A repertoire's map as a pandas DataFrame: the bundle's archive.csv (one row per elite,
sorted by cell: cell, forward_m (the fitness), lateral_m, yaw_deg, fell, energy_j,
timestep_s, the descriptor desc_<name>, each leg's contact share contact_<leg>, and the
gait's parameters x0..x<n-1> in the controller's unit cube), read from a job on the server
(``Job.archive()``) or from a downloaded bundle (``Bundle.archive``)."""

from __future__ import annotations

import io

ARCHIVE = "archive.csv"


def archive_frame(data: bytes):
    """archive.csv's bytes as a DataFrame: every float exactly as written (the CSV holds
    each number's shortest round-trip form), ``cell`` an integer, ``fell`` a bool."""
    import pandas as pd

    df = pd.read_csv(io.BytesIO(data))
    df["cell"] = df["cell"].astype("int64")
    df["fell"] = df["fell"].astype(bool)
    return df


def params_of(df, row) -> list[float]:
    """One elite's gait parameters (x0..x<n-1>) as a list, ready for the controller
    (controller/repertoire_controller.py in the bundle); ``row`` a label of ``df``."""
    cols = sorted((c for c in df.columns if c[:1] == "x" and c[1:].isdigit()), key=lambda c: int(c[1:]))
    return [float(v) for v in df.loc[row, cols]]


def _not_a_map(kind: str | None, what: str) -> ValueError:
    return ValueError(f"{what} is a {kind or 'unknown'} job: only a repertoire job's bundle holds {ARCHIVE}")


def job_archive(job):
    """``job``'s map (a succeeded repertoire job), fetched as the one bundle member."""
    kind = job.info.get("kind")
    if kind != "repertoire":
        raise _not_a_map(kind, f"job {job.id}")
    return archive_frame(job.client.request("GET", f"/api/jobs/{job.id}/files/{ARCHIVE}").content)


def bundle_archive(bundle):
    if ARCHIVE not in bundle.files:
        raise _not_a_map(bundle.kind, f"bundle {bundle.path.name}")
    return archive_frame(bundle.read(ARCHIVE))
