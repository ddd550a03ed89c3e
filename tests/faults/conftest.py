"""Fault injection against the real components (issue 27): helpers in fault_support.py.
Every deployment a test starts is closed afterwards, and every job error it wrote is
checked for SQL, parameters and tokens (check_errors)."""

from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

from fault_support import Stack, check_errors  # noqa: E402


@pytest.fixture
def stacks():
    """Start deployments with stacks(tmp_path, ...); each is closed and its job errors are
    checked when the test ends."""
    made: list[Stack] = []

    def start(*args, **kw) -> Stack:
        st = Stack(*args, **kw)
        made.append(st)
        return st

    yield start
    for st in made:
        st.close()
    for st in made:
        check_errors(st.settings)
