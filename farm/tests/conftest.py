"""Shared set-up of the farm tests: the package from this checkout, the binary, one small
LocalCluster (2 single-threaded worker processes on loopback) for the module's tests.

CAUSTIC_BINARY defaults to target/release/caustic of this repository; the tests fail when
it is missing (CI builds it first; a silent skip would hide a broken pipeline).
"""

import json
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(REPO, "farm"))  # spawned workers inherit sys.path
os.environ.setdefault("CAUSTIC_BINARY", os.path.join(REPO, "target", "release", "caustic"))
BINARY = os.environ["CAUSTIC_BINARY"]
CORNELL = os.path.join(REPO, "scenes", "cornell_box.gltf")


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    assert os.path.isfile(BINARY), f"build the binary first: {BINARY}"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


@pytest.fixture
def events():
    """A report callback that keeps the JSON objects (and checks they are JSON)."""
    seen = []

    def report(obj):
        seen.append(json.loads(json.dumps(obj)))
    report.seen = seen
    return report
