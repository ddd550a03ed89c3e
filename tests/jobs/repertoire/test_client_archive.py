"""The Python client reads a repertoire's map into a DataFrame: a small real job served by
`gaitmend serve` (embedded broker, SQLite), its archive.csv fetched by ``Job.archive()`` and
read from the downloaded bundle by ``Bundle.archive``; every elite of the job's summary is a
row, with its parameters, descriptor and metrics exactly."""

from __future__ import annotations

import httpx
import numpy as np
import pytest
from service_support import Proc, deployment, free_port, wait_for

import gaitmend

SPEC = {"kind": "repertoire", "seed": 3, "archive": {"cells": 20},
        "search": {"iterations": 3, "batch_size": 8, "checkpoint_every": 3},
        "sim": {"duration_s": 0.4, "settle_s": 0.1, "timestep_s": 0.002}, "evidence": {"rescore_elites": 2}}


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("served")
    env = deployment(tmp)
    port = free_port()
    proc = Proc(["serve", "--port", str(port)], env, tmp / "serve.log")
    base = f"http://127.0.0.1:{port}"

    def up():
        try:
            return httpx.get(f"{base}/api/health", timeout=2).status_code == 200
        except httpx.HTTPError:
            return False

    try:
        wait_for(up, 90, "the server", proc=proc)
        with gaitmend.Client(base, token="") as c:
            j = c.submit(SPEC).wait(progress=False, timeout=300)
            assert j.status == "succeeded", (j.info.get("error"), proc.tail())
            other = c.submit({"kind": "recovery", "damage": {"lost_legs": [3, 4]},
                              "search": {"population": 6, "generations": 1, "seed": 3}, "sim": {"duration_s": 0.5}})
            yield j, other, tmp
    finally:
        proc.stop()


def test_job_archive_is_every_elite_exactly(job):
    j, _, _ = job
    df = j.archive()
    e, s = j.summary["elites"], j.summary
    legs, names = s["robot"]["legs"], s["descriptor"]["names"]
    n, dim = len(e["cell"]), s["controller"]["parameters"]
    assert n == s["archive"]["elites"] > 0 and len(df) == n
    assert list(df.columns) == ["cell", "forward_m", "lateral_m", "yaw_deg", "fell", "energy_j", "timestep_s",
                                *[f"desc_{x}" for x in names], *[f"contact_{l}" for l in legs],
                                *[f"x{i}" for i in range(dim)]]
    assert df["cell"].tolist() == e["cell"] and df["cell"].dtype == np.int64 and df["fell"].dtype == bool
    assert df["forward_m"].tolist() == e["objective"]  # exactly: the CSV holds round-trip floats
    for k in ("lateral_m", "yaw_deg", "energy_j", "timestep_s"):
        assert df[k].tolist() == e[k]
    assert df["fell"].tolist() == [bool(v) for v in e["fell"]]
    assert df[[f"desc_{x}" for x in names]].to_numpy().tolist() == e["measures"]
    assert df[[f"contact_{l}" for l in legs]].to_numpy().tolist() == e["contact"]
    assert df[[f"x{i}" for i in range(dim)]].to_numpy().tolist() == e["solution"]
    best = int(df["forward_m"].idxmax())
    assert df.loc[best, "forward_m"] == s["best"]["forward_m"] and df.loc[best, "cell"] == s["best"]["cell"]
    assert gaitmend.Client.__module__  # the package's names are unchanged
    from app.client.repertoire import params_of

    assert params_of(df, best) == s["best"]["params"]


def test_bundle_archive_is_the_same_table(job):
    j, _, tmp = job
    b = j.open_bundle(tmp / "map.zip")
    assert b.archive.equals(j.archive())


def test_a_job_of_another_kind_has_no_archive(job):
    _, other, _ = job
    with pytest.raises(ValueError, match="recovery job: only a repertoire job"):
        other.archive()
