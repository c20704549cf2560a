"""The environment checks set ``DRJIT_LIBLLVM_PATH`` in ``os.environ`` as they do for a user; these
tests point it at fake libraries, so every test gets the variables back as they were (monkeypatch's
``delenv`` of an unset variable records nothing, and a fake path left behind broke every later
test that starts a rigsim process)."""

import os

import pytest

_KEYS = ("DRJIT_LIBLLVM_PATH", "RIGSIM_LLVM_CHECK", "RIGSIM_MITSUBA_VARIANT")


@pytest.fixture(autouse=True)
def _restore_llvm_environment():
    saved = {k: os.environ.get(k) for k in _KEYS}
    yield
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v
