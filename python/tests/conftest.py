"""Shared helpers: the repository, the djkr command line (whose output every test compares
with), and a runner for it."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def djkr_bin() -> Path:
    """The command line built by `cargo test` (DJKR_BIN), else the release build."""
    env = os.environ.get("DJKR_BIN")
    path = Path(env) if env else ROOT / "target" / "release" / "djkr"
    if not path.exists():
        pytest.fail(f"djkr binary not found at {path}: build it (cargo build --release) or set DJKR_BIN")
    return path


def cli(*args, check=True):
    """Run `djkr ARGS` from the repository root; the completed process."""
    p = subprocess.run(
        [str(djkr_bin()), *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if check and p.returncode != 0:
        raise AssertionError(f"djkr {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr}")
    return p


def cli_json(*args):
    """`djkr ARGS --json`, parsed."""
    return json.loads(cli(*args, "--json").stdout)


def cli_error(*args):
    """The one-line error of a `djkr ARGS` that must fail, without its `error: ` prefix."""
    p = cli(*args, check=False)
    assert p.returncode == 2, p
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), line
    return line[len("error: "):]


@pytest.fixture
def root():
    return ROOT
