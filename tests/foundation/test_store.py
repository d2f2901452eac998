"""The object-store contract, run against a real MinIO and against a local directory."""

from __future__ import annotations

import time

import pytest

from racer.local.services import free_port
from racer.shared.config import S3Settings
from racer.shared.store import (
    BucketNotFoundError,
    LocalStore,
    ObjectNotFoundError,
    S3Store,
    StoreUnavailableError,
    open_store,
)


@pytest.fixture(params=["s3", "local"])
def store(request, tmp_path):
    if request.param == "s3":
        return open_store(request.getfixturevalue("s3_settings"))
    return LocalStore(tmp_path / "bucket")


def test_put_get_overwrite_delete(store):
    store.put_bytes("model-a/model/.coach_checkpoint", b"0_Step-0.ckpt")
    assert store.get_bytes("model-a/model/.coach_checkpoint") == b"0_Step-0.ckpt"
    store.put_bytes("model-a/model/.coach_checkpoint", b"1_Step-519.ckpt")
    assert store.get_bytes("model-a/model/.coach_checkpoint") == b"1_Step-519.ckpt"
    assert store.exists("model-a/model/.coach_checkpoint")
    assert store.size("model-a/model/.coach_checkpoint") == len(b"1_Step-519.ckpt")
    store.delete("model-a/model/.coach_checkpoint")
    assert not store.exists("model-a/model/.coach_checkpoint")
    store.delete("model-a/model/.coach_checkpoint")  # deleting twice is fine


def test_list_by_prefix(store):
    keys = ["m/model/0_Step-0.ckpt.data", "m/model/0_Step-0.ckpt.index", "m/ip/hyperparameters.json", "m2/model/x"]
    for key in keys:
        store.put_bytes(key, key.encode())
    assert store.list_keys("m/model/") == sorted(keys[:2])
    assert store.list_keys("m/") == sorted(keys[:3])
    assert store.list_keys("m") == sorted(keys)
    assert store.list_keys("nothing-here/") == []


def test_binary_round_trip(store):
    payload = bytes(range(256)) * 4096  # 1 MiB with every byte value
    store.put_bytes("m/blob.bin", payload)
    assert store.get_bytes("m/blob.bin") == payload


def test_missing_key_is_a_clear_error(store):
    with pytest.raises(ObjectNotFoundError) as caught:
        store.get_bytes("m/model/missing.json")
    assert "m/model/missing.json" in str(caught.value)
    assert store.describe() in str(caught.value)


def test_invalid_keys_are_rejected(store):
    for key in ["/abs", "a//b", "a/../b", ""]:
        with pytest.raises(ValueError):
            store.put_bytes(key, b"x")


def test_missing_bucket(minio_server):
    store = S3Store(
        S3Settings(
            bucket="no-such-bucket",
            endpoint_url=minio_server.endpoint_url,
            access_key_id=minio_server.access_key,
            secret_access_key=minio_server.secret_key,
        )
    )
    with pytest.raises(BucketNotFoundError, match="no-such-bucket"):
        store.get_bytes("k")


@pytest.mark.serial  # asserts a wall-time bound
def test_unreachable_minio_fails_fast():
    port = free_port()  # nothing listens here
    store = S3Store(
        S3Settings(
            bucket="b",
            endpoint_url=f"http://127.0.0.1:{port}",
            access_key_id="x",
            secret_access_key="y",
            connect_timeout_s=2.0,
        )
    )
    started = time.monotonic()
    with pytest.raises(StoreUnavailableError, match=f"127.0.0.1:{port}"):
        store.put_bytes("k", b"v")
    assert time.monotonic() - started < 30


def test_local_store_has_no_partial_files(tmp_path):
    store = LocalStore(tmp_path)
    store.put_bytes("a/b.json", b"{}")
    assert store.list_keys("") == ["a/b.json"]  # the staging folder never shows


def test_settings_from_environment_read_s3_and_session_token():
    from racer.shared.config import settings_from_env

    settings = settings_from_env(
        {
            "RACER_STORE": "s3://models",
            "S3_ENDPOINT_URL": "http://127.0.0.1:9000",
            "AWS_ACCESS_KEY_ID": "id",
            "AWS_SECRET_ACCESS_KEY": "secret",
            "AWS_SESSION_TOKEN": "token",
            "RACER_REDIS_URL": "redis://r:6379/1",
        }
    )
    assert settings.store == S3Settings(
        bucket="models",
        endpoint_url="http://127.0.0.1:9000",
        access_key_id="id",
        secret_access_key="secret",
        session_token="token",
        connect_timeout_s=10.0,
    )
    assert settings.redis.url == "redis://r:6379/1"
    with pytest.raises(ValueError, match="s3://<bucket>"):
        settings_from_env({"RACER_STORE": "s3://bucket/with/prefix"})


def test_a_store_named_on_the_command_line_takes_endpoint_keys_and_timeout_from_the_environment(tmp_path):
    from racer.shared.config import LocalStoreSettings, store_settings_at

    env = {"RACER_STORE": "s3://other", "S3_ENDPOINT_URL": "http://minio:9000", "RACER_CONNECT_TIMEOUT_S": "3"}
    assert store_settings_at("s3://models", env) == S3Settings(
        bucket="models", endpoint_url="http://minio:9000", connect_timeout_s=3.0
    )
    assert store_settings_at(str(tmp_path / "store"), env) == LocalStoreSettings(root=tmp_path / "store")


def test_deepracer_data_is_unset_unless_the_variable_names_a_folder(tmp_path):
    from racer.shared.config import deepracer_data

    assert deepracer_data({}) is None and deepracer_data({"RACER_DEEPRACER_DATA": " "}) is None
    assert deepracer_data({"RACER_DEEPRACER_DATA": str(tmp_path / "data")}) == tmp_path / "data"


def test_a_restarted_minio_keeps_the_objects_and_the_store_reconnects(tmp_path):
    """Tests (and users) can restart MinIO: data stays on disk, and the same S3Store goes on working."""
    from racer.local.services import MinioServer

    with MinioServer(tmp_path / "minio") as server:
        store = S3Store(
            S3Settings(
                bucket="restart",
                endpoint_url=server.endpoint_url,
                access_key_id=server.access_key,
                secret_access_key=server.secret_key,
                connect_timeout_s=10.0,
            )
        )
        store.ensure_bucket()
        store.put_bytes("model/.coach_checkpoint", b"3_Step-300.ckpt")
        old_pid = server.pid
        server.restart(timeout_s=60)
        assert server.pid != old_pid
        assert store.get_bytes("model/.coach_checkpoint") == b"3_Step-300.ckpt"
        store.put_bytes("model/.finished", b"")
        assert store.list_keys("model/") == ["model/.coach_checkpoint", "model/.finished"]
