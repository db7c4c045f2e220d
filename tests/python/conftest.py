"""Shared fixtures of the Python tests (run by CTest: tests/CMakeLists.txt sets the environment)."""
import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _env_true(name):
    v = os.environ.get(name, "")
    return v not in ("", "0", "false")


def data_file(rel):
    """A file of ../shared/data; skipped when absent on a developer's machine, a failure in CI."""
    path = pathlib.Path(os.environ.get("MOUNTCAL_SHARED_DIR", ROOT.parent / "shared")) / "data" / rel
    if not path.exists():
        if _env_true("MOUNTCAL_REQUIRE_REAL_DATA") or _env_true("CI"):
            pytest.fail(f"real data not found in CI: {path} (../shared must be beside the repository)")
        pytest.skip(f"real data not found: {path}")
    return path


@pytest.fixture(scope="session")
def cli():
    """The mountcal command of the same build."""
    path = os.environ.get("MOUNTCAL_CLI")
    if not path or not os.path.exists(path):
        pytest.fail("MOUNTCAL_CLI is not set to the built mountcal command (run the tests through CTest)")
    return path


@pytest.fixture(scope="session")
def examples():
    return ROOT / "examples"


def command_env():
    """The environment for the mountcal command: without the sanitizer runtime the interpreter was
    started with (LD_PRELOAD, sanitizer build) — the command carries its own."""
    env = dict(os.environ)
    env.pop("LD_PRELOAD", None)
    return env
