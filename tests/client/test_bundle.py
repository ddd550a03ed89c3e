"""gaitmend.open_bundle on a real bundle of every kind (fetched from the served instance),
as a zip and unpacked: manifest, summary, history and traces as DataFrames, trajectories as
arrays, the damaged MjModel, the kind's figures; verify() as `gaitmend verify`."""

from __future__ import annotations

import json
import zipfile

import mujoco
import numpy as np
import pandas as pd
import pytest

import gaitmend
from app.jobs.registry import KINDS


@pytest.mark.parametrize("kind", sorted(k for k, v in KINDS.items() if v.smoke_spec()))
def test_open_bundle_of_every_kind(kind, bundles, finished, tmp_path):
    zipped = gaitmend.open_bundle(bundles[kind])
    with zipfile.ZipFile(bundles[kind]) as z:
        z.extractall(tmp_path / "unpacked")
    for b in (zipped, gaitmend.open_bundle(tmp_path / "unpacked"), gaitmend.open_bundle(tmp_path / "unpacked" /
                                                                                        "manifest.json")):
        assert b.kind == kind and b.job_id == finished[kind].id
        assert b.manifest["spec"] == finished[kind].spec and b.spec["kind"] == kind
        assert b.summary == finished[kind].summary
        assert isinstance(b.history, pd.DataFrame) and len(b.history) == len(finished[kind].history)
        assert b.trace_names and set(b.trajectories) == set(b.trace_names)
        for name in b.trace_names:
            arrays = b.trajectories[name]
            assert all(isinstance(v, np.ndarray) for v in arrays.values())
            df = b.trace(name)
            assert df.index.name == "time_s" and len(df) == len(arrays["time_s"])
        assert isinstance(b.model, mujoco.MjModel) and b.model.nbody > 1
        assert b.robot_xml.startswith("<mujoco")
        figs = b.figures
        assert figs and all(f.png or f.svg for f in figs.values())
        first = next(iter(figs.values()))
        assert first.description and (first._repr_png_() or first._repr_svg_())
        assert first.save(tmp_path / f"{first.name}.png").stat().st_size > 100
        assert list(b.headline["label"]) == [r["label"] for r in finished[kind].info["headline"]]
        assert b.readme.startswith("# gaitmend result bundle")
    assert json.loads(zipped.read("manifest.json"))["kind"] == kind


def test_bundle_verify_reruns_and_compares(bundles, tmp_path):
    b = gaitmend.open_bundle(bundles["recovery"])
    v = b.verify()
    assert v and v.same and v.outcome == "identical" and v.difference is None and v.comparison.numbers > 100
    # a number changed in result.json is found, named by its path
    with zipfile.ZipFile(bundles["recovery"]) as z:
        z.extractall(tmp_path / "b")
    res = json.loads((tmp_path / "b" / "result.json").read_text())
    res["best"]["fitness"] += 1.0
    (tmp_path / "b" / "result.json").write_text(json.dumps(res))
    v = gaitmend.open_bundle(tmp_path / "b").verify()
    assert not v and not v.same and v.outcome == "different" and v.difference.startswith("best.fitness")
    assert v.comparison.differing == 1 and v.comparison.where == "best.fitness"


def test_not_a_bundle(tmp_path):
    (tmp_path / "x.zip").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a bundle"):
        gaitmend.open_bundle(tmp_path / "x.zip")
    with zipfile.ZipFile(tmp_path / "y.zip", "w") as z:
        z.writestr("hello.txt", "hi")
    with pytest.raises(ValueError, match="no manifest.json"):
        gaitmend.open_bundle(tmp_path / "y.zip")
