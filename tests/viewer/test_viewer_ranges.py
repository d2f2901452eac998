"""`/files` answers HTTP Range on an S3 store (a real MinIO) as on a local one: 206 with Content-Range, 416 past the
end, the whole object with Accept-Ranges otherwise, so videos seek in the compose deployment."""

from __future__ import annotations

import http.client
import os

import pytest

from racer.shared.store import LocalStore, S3Store
from racer.viewer.app import create_app
from racer.viewer.object_ranges import UnsatisfiableRange, requested_range
from racer.viewer.run_reader import RunLocation, RunReader
from tests.viewer.conftest import ServedApp

VIDEO_KEY = "range-model/evaluation/run-1/top.mp4"
VIDEO = os.urandom(700_000)  # larger than one streamed chunk (256 KiB)


def request(port: int, path: str, range_header: str | None = None) -> tuple[int, dict[str, str], bytes]:
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    connection.request("GET", path, headers={"Range": range_header} if range_header else {})
    response = connection.getresponse()
    body = response.read()
    headers = {name.lower(): value for name, value in response.getheaders()}
    connection.close()
    return response.status, headers, body


@pytest.fixture(params=["s3", "local"])
def served(request, tmp_path):
    if request.param == "s3":
        store = S3Store(request.getfixturevalue("s3_settings"))
    else:
        store = LocalStore(tmp_path / "store")
    store.put_bytes(VIDEO_KEY, VIDEO)
    store.put_bytes("range-model/metrics/empty.json", b"")
    with ServedApp(create_app(RunReader(RunLocation(store, "range-model")), None)) as app:
        yield app


def test_ranges_of_a_video(served):
    path = "/files/evaluation/run-1/top.mp4"
    size = len(VIDEO)
    status, headers, body = request(served.port, path)
    assert (status, body, headers["accept-ranges"], headers["content-type"]) == (200, VIDEO, "bytes", "video/mp4")
    assert headers["content-length"] == str(size)

    for header, first, last in [
        ("bytes=0-1", 0, 1),
        ("bytes=1000-300999", 1000, 300999),  # spans two streamed chunks
        (f"bytes={size - 10}-", size - 10, size - 1),
        ("bytes=-500", size - 500, size - 1),
        (f"bytes=690000-{size + 5000}", 690000, size - 1),  # clipped to the object
    ]:
        status, headers, body = request(served.port, path, header)
        assert status == 206, header
        assert body == VIDEO[first : last + 1], header
        assert headers["content-range"] == f"bytes {first}-{last}/{size}", header
        assert headers["content-length"] == str(last - first + 1), header

    status, headers, body = request(served.port, path, f"bytes={size}-")
    assert status == 416 and headers["content-range"] == f"bytes */{size}"
    assert request(served.port, "/files/evaluation/run-1/missing.mp4", "bytes=0-1")[0] == 404


def test_an_empty_file_and_a_range_on_it(served):
    status, _headers, body = request(served.port, "/files/metrics/empty.json")
    assert (status, body) == (200, b"")
    assert request(served.port, "/files/metrics/empty.json", "bytes=0-")[0] == 416


def test_requested_range_reading():
    assert requested_range(None, 100) is None
    assert requested_range("bytes=0-0,5-6", 100) is None  # several ranges: the whole object
    assert requested_range("items=0-5", 100) is None
    assert requested_range("bytes=9-3", 100) is None  # invalid: ignored
    assert requested_range("bytes=-1000", 100) == (0, 99)
    assert requested_range("bytes=99-", 100) == (99, 99)
    with pytest.raises(UnsatisfiableRange):
        requested_range("bytes=-0", 100)
    with pytest.raises(UnsatisfiableRange):
        requested_range("bytes=100-", 100)
