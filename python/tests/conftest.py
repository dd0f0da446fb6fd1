"""Shared fixtures: the repository root (scenario paths are relative to it) and the formica
command-line binary that `formica.run` is checked against."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SEED_TRANSPORT = "scenarios/seed-transport.toml"


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    """Every test runs in the repository root, as the README's commands do."""
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="session")
def formica_bin() -> str:
    """The `formica` binary: $FORMICA_BIN, else target/release/formica, else one on PATH."""
    candidates = [os.environ.get("FORMICA_BIN"), str(ROOT / "target/release/formica"), shutil.which("formica")]
    for c in candidates:
        if c and os.access(c, os.X_OK) and not os.path.isdir(c):
            return c
    pytest.fail("no formica binary: build it with `cargo build --release -p formica-cli` or set FORMICA_BIN")
