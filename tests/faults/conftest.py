"""Fault tests: every run gets its own folder of turntable locks (RIG_LOCK_DIR), inherited by subprocesses."""

import pytest


@pytest.fixture(autouse=True)
def private_lock_dir(tmp_path, monkeypatch):
    folder = tmp_path / "locks"
    monkeypatch.setenv("RIG_LOCK_DIR", str(folder))
    return folder
