# pytest set-up for the Python module's tests (tests/python/CMakeLists.txt
# runs them with PYTHONPATH=<build>/python and HRAD_CLI=<the hrad binary>).
import os
import pathlib
import shutil
import tempfile

import pytest


@pytest.fixture()
def tmp_path():
    # pytest's own tmp_path keeps the last runs' folders; ours are removed.
    with tempfile.TemporaryDirectory(prefix="hrad-pytest-") as d:
        yield pathlib.Path(d)


@pytest.fixture(scope="session")
def hrad_cli():
    cli = os.environ.get("HRAD_CLI") or shutil.which("hrad")
    if not cli:
        pytest.skip("HRAD_CLI (the hrad binary) not set")
    return cli


@pytest.fixture()
def cache_dir(tmp_path):
    # References never go to the user's cache from a test.
    d = tmp_path / "cache"
    d.mkdir()
    return d
