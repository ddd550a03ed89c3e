"""The dashboard's two plotly.js bundles (app/api/routes/dashboard.py): the full one from the
pinned plotly package and the vendored cartesian build (web/vendor, scripts/vendor_plotly.sh)
are one plotly.js release; each page's head names both by a versioned URL; both go with V8's
compile hint before the file's own bytes, gzipped on request; an unknown script name is a 404
naming the ones there are."""

from __future__ import annotations

import gzip
import re

import pytest
from fastapi.testclient import TestClient
from service_support import deployment, migrated

from app.api import create_app
from app.api.routes.dashboard import COMPILE_HINT, PLOTLY_BUNDLES, _plotly_js


def _release(path) -> str:
    return re.search(r"plotly\.js (?:\([a-z -]+\) )?v([0-9.]+)", path.read_text()[:300]).group(1)


def test_the_bundles_are_one_release_and_the_cartesian_one_is_smaller():
    full, cart = _plotly_js("plotly"), _plotly_js("plotly-cartesian")
    assert _release(full) == _release(cart), "re-run scripts/vendor_plotly.sh after changing the plotly pin"
    assert "cartesian" in cart.read_text()[:100]
    assert cart.stat().st_size < full.stat().st_size / 2.5


@pytest.fixture
def client(tmp_path):
    with TestClient(create_app(migrated(deployment(tmp_path)))) as c:
        yield c


def test_pages_name_both_bundles_and_each_goes_gzipped(client):
    page = client.get("/jobs/whatever").text
    sizes = {}
    for name in PLOTLY_BUNDLES:
        url = re.search(rf'<meta name="gm-{name}" content="([^"]+)"', page).group(1)
        assert url.startswith(f"/vendor/{name}.min.js?v=")
        r = client.get(url, headers={"Accept-Encoding": "gzip"})
        assert r.status_code == 200 and r.headers["content-encoding"] == "gzip", name
        assert "immutable" in r.headers["cache-control"] and b"plotly.js" in r.content[:200]
        sizes[name] = len(r.content)
    assert sizes["plotly-cartesian"] < sizes["plotly"] / 2.5, sizes
    # the job page preloads the bundle it draws with (the cartesian one)
    assert re.search(r'<link rel="preload" href="/vendor/plotly-cartesian\.min\.js\?v=', page)
    r = client.get("/vendor/jquery.min.js")
    assert r.status_code == 404 and r.json()["errors"][0]["field"] == "name"
    assert "plotly-cartesian" in r.json()["detail"]


def test_both_bundles_start_with_the_compile_hint_and_are_otherwise_the_files_bytes(client):
    """Chrome compiles a script that starts with //# allFunctionsCalledOnLoad while it streams
    in, off the page's thread; the rest is the bundle's file byte for byte, gzipped on the
    wire when the browser takes it and plain when it does not."""
    assert COMPILE_HINT == b"//# allFunctionsCalledOnLoad\n"
    page = client.get("/jobs/whatever").text
    for name in PLOTLY_BUNDLES:
        want = COMPILE_HINT + _plotly_js(name).read_bytes()
        url = re.search(rf'<meta name="gm-{name}" content="([^"]+)"', page).group(1)
        with client.stream("GET", url, headers={"Accept-Encoding": "gzip"}) as r:
            wire = b"".join(r.iter_raw())
            assert r.headers["content-encoding"] == "gzip", name
        assert wire[:2] == b"\x1f\x8b" and gzip.decompress(wire) == want, name
        assert len(wire) < len(want) / 2.5, (name, len(wire), len(want))  # 4.8 MB -> 1.4, 1.5 -> 0.5
        plain = client.get(url, headers={"Accept-Encoding": "identity"})
        assert "content-encoding" not in plain.headers and plain.content == want, name
        assert plain.headers["content-type"].startswith("text/javascript")
