"""The CLI starts without the plotting and search libraries: every `gaitmend` command (and
every worker and server the suite starts) imports app.cli first, and matplotlib alone cost
about 1.3 s of a 4.8 s start on a two-core host. They load when a plot is drawn or a map is
searched."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("matplotlib", "ribs", "numba", "torch", "scipy.optimize", "casadi", "viser")


def test_importing_the_cli_leaves_the_heavy_libraries_unloaded():
    code = ("import json, sys; from app.cli import main; "
            f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
