#!/usr/bin/env bash
# Vendors plotly.js's cartesian bundle (scatter, bar, heatmap; most dashboard pages draw only
# these) from npm at the plotly.js release the pinned plotly package ships, so both bundles
# the dashboard serves are one release (tests/api/test_vendor.py checks it). Run it after
# changing the plotly pin in pyproject.toml; needs npm and the project's venv.
set -euo pipefail
cd "$(dirname "$0")/.."
v=$(python - <<'PY'
import pathlib, re, plotly
head = (pathlib.Path(plotly.__file__).parent / "package_data" / "plotly.min.js").read_text()[:300]
print(re.search(r"plotly\.js v([0-9.]+)", head).group(1))
PY
)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && npm pack -q "plotly.js-cartesian-dist-min@$v" >/dev/null && tar xzf ./*.tgz)
mkdir -p web/vendor
cp "$tmp/package/plotly-cartesian.min.js" web/vendor/plotly-cartesian.min.js
cp "$tmp/package/LICENSE" web/vendor/LICENSE-plotly.js.txt
echo "web/vendor/plotly-cartesian.min.js: plotly.js $v ($(wc -c < web/vendor/plotly-cartesian.min.js) bytes)"
