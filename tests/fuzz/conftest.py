"""The fuzz tests: a fixed seed and a few dozen cases per test (CI runs them in about a minute);
``tools/soak.py`` runs the same strategies for 10 000 cases."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, settings

#: Fixed examples (derandomize: the same cases every run), no example database, no deadline.
settings.register_profile("rigsim-fuzz", derandomize=True, database=None, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                                 HealthCheck.filter_too_much])


@pytest.fixture(scope="session")
def ws(tmp_path_factory):
    from tests.fuzz.cases import Workspace

    w = Workspace(tmp_path_factory.mktemp("fuzz"))
    yield w
    w.close()
