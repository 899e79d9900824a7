"""Shared fixtures: the `tandem` command-line binary the Python results are compared with."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    """Run the `tandem` binary (TANDEM_BIN, else <repo>/target/release/tandem); returns
    CompletedProcess. The tests fail, never skip, when it is missing: they exist to compare."""
    exe = os.environ.get("TANDEM_BIN") or str(REPO / "target" / "release" / "tandem")
    if not os.path.isfile(exe):
        pytest.fail(
            f"the tandem binary {exe} is missing: build it with `cargo build --release -p tandem-cli` "
            "or set TANDEM_BIN"
        )

    def run(*args, cwd=None, check=True):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, cwd=cwd)
        if check and p.returncode != 0:
            raise AssertionError(f"tandem {' '.join(map(str, args))} failed:\n{p.stderr}")
        return p

    return run
