#!/usr/bin/env bash
# The README's second command: install the test dependencies and run every test.
# Idempotent; used as-is by CI (.ci/run). Starts what the tests need and is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
. .venv/bin/activate
python -m pip install -q --upgrade pip >/dev/null
python -m pip install -q -e '.[test]'

# Browser tests drive Debian's Chromium (never a downloaded browser).
if [ -f tests/e2e/conftest.py ] && [ ! -x /usr/bin/chromium ] && command -v apt-get >/dev/null; then
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
    || echo "warning: could not install chromium; browser tests will fail" >&2
fi
# Videos (app/results/video.py, `gaitmend video`, the job page's MP4) render with MuJoCo's
# offscreen renderer on software OpenGL: EGL with Mesa's llvmpipe, no display or GPU. Debian:
# libegl1 (EGL dispatch), libegl-mesa0 (Mesa's EGL), libgl1-mesa-dri (llvmpipe), libgl1 and
# libopengl0 (the GL entry points PyOpenGL loads).
if [ -d tests/client ] && ! ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa.so.0' && command -v apt-get >/dev/null; then
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
     libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libopengl0 >/dev/null) \
    || echo "warning: could not install Mesa's EGL (libegl-mesa0, libgl1-mesa-dri); video tests will fail" >&2
fi
# Redis and PostgreSQL run on this machine and in CI; start them if they stopped.
if command -v redis-cli >/dev/null && ! redis-cli -h 127.0.0.1 ping >/dev/null 2>&1; then
  redis-server --daemonize yes --bind 127.0.0.1 --port 6379 --save "" --appendonly no >/dev/null || true
fi
if command -v pg_isready >/dev/null && ! pg_isready -h 127.0.0.1 -q 2>/dev/null; then
  pg_ctlcluster --skip-systemctl-redirect "$(ls /etc/postgresql | head -1)" main start 2>/dev/null || true
fi

# The suite writes nothing into the checkout (tests/conftest.py fails the run if it does);
# bytecode caches go to a temporary folder too. They are written even where the environment
# says not to (PYTHONDONTWRITEBYTECODE, set on this project's CI machines): without them every
# process the suite starts (each `gaitmend` command, server and worker) compiles app/'s 650
# modules again, 1.7 s of a 2.9 s start against 1.1 s with them.
export PYTHONPYCACHEPREFIX="${TMPDIR:-/tmp}/gaitmend-pycache"
unset PYTHONDONTWRITEBYTECODE
# Two parts. Most tests wait on processes they start (workers, servers, a browser), so they
# run on two pytest-xdist workers, a whole file per worker (a file's module fixtures run
# once). Three gained nothing before bytecode was cached (1,264 s against 1,272 s) and are
# slower with it: on AMD EPYC family 25 model 1 the parallel part took 1,309 s on three
# against 1,192 s on two. The tests marked `serial` (fault injection against the real
# services, with wall-clock bounds: tests/faults) then run alone.
# GAITMEND_TEST_WORKERS=N sets the count, 0 runs everything in one process; a `-m` of the
# caller's runs its selection once, in parallel.
WORKERS=${GAITMEND_TEST_WORKERS:-2}
own_m=0
for a in "$@"; do case "$a" in -m|-m*) own_m=1 ;; esac; done
set +e
if [ "$WORKERS" = "0" ]; then
  python -m pytest "$@"; rc=$?
elif [ "$own_m" = "1" ]; then
  python -m pytest -n "$WORKERS" --dist loadfile "$@"; rc=$?
else
  python -m pytest -n "$WORKERS" --dist loadfile -m "not serial" "$@"; rc1=$?
  python -m pytest -m serial "$@"; rc2=$?
  # exit 5: that part collected nothing (a selection of the caller's can leave one part empty)
  if [ "$rc1" -eq 5 ] && [ "$rc2" -eq 5 ]; then rc=5
  elif [ "$rc1" -ne 0 ] && [ "$rc1" -ne 5 ]; then rc=$rc1
  elif [ "$rc2" -ne 0 ] && [ "$rc2" -ne 5 ]; then rc=$rc2
  else rc=0; fi
fi
set -e
# Exit 5 means pytest collected nothing: a broken checkout, so say so and fail.
if [ "$rc" -eq 5 ]; then
  echo "pytest collected no tests" >&2
fi
exit "$rc"
