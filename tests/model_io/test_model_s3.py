"""`validate` and `import` against a real MinIO: missing bucket, denied reads and writes, unknown credentials,
an unreachable endpoint, and the folder matrix uploaded to a bucket.

Access denial is real, both ways MinIO does it: a MinIO user created through the admin API (the `minio`
package's MinioAdmin) with a policy attached, and temporary credentials from MinIO's STS AssumeRole API with a
session policy. MinIO enforces the policy on every request. No `mc` client is needed.
"""

from __future__ import annotations

import json

import boto3
import pytest
from click.testing import CliRunner

from racer.cli import main
from racer.local.services import free_port
from racer.model_io import ProblemCode, SizeLimits, StoreSource, import_model, validate_model
from racer.model_io.sources import FolderSource
from racer.shared.config import S3Settings
from racer.shared.store import LocalStore, S3Store
from tests.model_io.model_io_builders import BROKEN, deepracer_model, upload

pytestmark = pytest.mark.usefixtures("deepracer_data")  # the builders read ../shared/deepracer-data

Code = ProblemCode
PREFIX = "DeepRacer-SageMaker-RoboMaker-comm-1234-model"


def session_policy(bucket: str, allow: list[str], deny: list[str]) -> str:
    statements = [
        {"Effect": "Allow", "Action": allow, "Resource": [f"arn:aws:s3:::{bucket}", f"arn:aws:s3:::{bucket}/*"]}
    ]
    if deny:
        statements.append(
            {"Effect": "Deny", "Action": deny, "Resource": [f"arn:aws:s3:::{bucket}", f"arn:aws:s3:::{bucket}/*"]}
        )
    return json.dumps({"Version": "2012-10-17", "Statement": statements})


@pytest.fixture
def restricted_credentials(minio_server, monkeypatch, tmp_path):
    """Returns a function: (policy) -> S3Settings whose requests run as a MinIO STS user limited by `policy`.

    S3Settings has no session-token field, so the temporary credentials reach boto3 through its standard
    environment variables (access key fields left empty)."""
    sts = boto3.client(
        "sts",
        endpoint_url=minio_server.endpoint_url,
        region_name="us-east-1",
        aws_access_key_id=minio_server.access_key,
        aws_secret_access_key=minio_server.secret_key,
    )

    def make(bucket: str, policy: str) -> S3Settings:
        credentials = sts.assume_role(
            RoleArn="arn:minio:iam:::role/racer-test", RoleSessionName="racer-test", Policy=policy, DurationSeconds=900
        )["Credentials"]
        monkeypatch.setenv("AWS_ACCESS_KEY_ID", credentials["AccessKeyId"])
        monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", credentials["SecretAccessKey"])
        monkeypatch.setenv("AWS_SESSION_TOKEN", credentials["SessionToken"])
        monkeypatch.setenv("AWS_SHARED_CREDENTIALS_FILE", str(tmp_path / "no-credentials"))
        monkeypatch.setenv("AWS_CONFIG_FILE", str(tmp_path / "no-config"))
        monkeypatch.delenv("AWS_PROFILE", raising=False)
        monkeypatch.setattr(boto3, "DEFAULT_SESSION", None)  # its credential cache would keep the previous keys
        return S3Settings(bucket=bucket, endpoint_url=minio_server.endpoint_url, connect_timeout_s=5.0)

    return make


@pytest.fixture
def s3_model(s3_settings, tmp_path):
    """A valid console-style model uploaded to the test bucket under PREFIX."""
    folder = deepracer_model(tmp_path / "model", best="3_Step-124.ckpt", last="4_Step-162.ckpt")
    upload(folder, S3Store(s3_settings), PREFIX)
    return s3_settings


def cli_env(settings: S3Settings, **overrides: str) -> dict[str, str]:
    env = {
        "S3_ENDPOINT_URL": settings.endpoint_url,
        "AWS_ACCESS_KEY_ID": settings.access_key_id,
        "AWS_SECRET_ACCESS_KEY": settings.secret_access_key,
        "RACER_CONNECT_TIMEOUT_S": "3",
    }
    env.update(overrides)
    return env


def test_a_valid_model_in_a_bucket_passes(s3_model):
    result = CliRunner().invoke(main, ["model", "validate", f"s3://{s3_model.bucket}/{PREFIX}"], env=cli_env(s3_model))
    assert result.exit_code == 0, result.output
    assert "OK" in result.output and "3_Step-124.ckpt, 4_Step-162.ckpt" in result.output


def test_missing_bucket(s3_model):
    result = CliRunner().invoke(
        main, ["model", "validate", f"s3://no-such-bucket-here/{PREFIX}"], env=cli_env(s3_model)
    )
    assert result.exit_code == 1
    assert result.output.startswith("SRC_BUCKET_DOES_NOT_EXIST")
    assert result.output.count("fix:") == 1


def test_nothing_under_the_prefix(s3_model):
    result = CliRunner().invoke(
        main, ["model", "validate", f"s3://{s3_model.bucket}/deleted-model"], env=cli_env(s3_model)
    )
    assert result.exit_code == 1
    assert result.output.startswith("FILE_DOES_NOT_EXIST")
    assert result.output.count("fix:") == 1


def test_unknown_access_key(s3_model):
    env = cli_env(s3_model, AWS_ACCESS_KEY_ID="nobody-has-this-key", AWS_SECRET_ACCESS_KEY="wrong-secret-123")
    result = CliRunner().invoke(main, ["model", "validate", f"s3://{s3_model.bucket}/{PREFIX}"], env=env)
    assert result.exit_code == 1
    assert result.output.startswith("ACCOUNT_RESOURCE_DOES_NOT_EXIST"), result.output
    assert result.output.count("fix:") == 1


def test_unreachable_endpoint(s3_model):
    env = cli_env(s3_model, S3_ENDPOINT_URL=f"http://127.0.0.1:{free_port()}")
    result = CliRunner().invoke(main, ["model", "validate", f"s3://{s3_model.bucket}/{PREFIX}"], env=env)
    assert result.exit_code == 1
    assert result.output.startswith("SERVICE_ERROR"), result.output
    assert result.output.count("fix:") == 1


@pytest.mark.parametrize("denied", [["s3:ListBucket"], ["s3:GetObject"]])
def test_a_user_whose_policy_denies_reads(s3_model, restricted_credentials, denied):
    allowed = ["s3:ListBucket", "s3:GetObject", "s3:GetBucketLocation"]
    settings = restricted_credentials(s3_model.bucket, session_policy(s3_model.bucket, allowed, denied))
    report = validate_model(StoreSource(S3Store(settings), PREFIX))
    assert report.codes == [Code.ACCESS_DENIED_TO_BUCKET], report.problems
    assert "access denied" in report.problems[0].message
    # The same credentials with nothing denied can read the model: the denial is the policy's doing.
    settings = restricted_credentials(s3_model.bucket, session_policy(s3_model.bucket, allowed, []))
    assert validate_model(StoreSource(S3Store(settings), PREFIX)).ok


@pytest.mark.parametrize("denied", ["s3:ListBucket", "s3:GetObject"])
def test_a_minio_user_whose_policy_denies_reads(s3_model, minio_server, denied):
    """A real MinIO user (created through MinIO's admin API, as docker compose's minio-setup does) with a policy
    that allows reading the bucket but denies one read action: `racer model validate` says ACCESS_DENIED_TO_BUCKET."""
    from minio import MinioAdmin
    from minio.credentials import StaticProvider

    admin = MinioAdmin(
        endpoint=minio_server.endpoint_url.split("://", 1)[1],
        secure=False,
        credentials=StaticProvider(minio_server.access_key, minio_server.secret_key),
    )
    user, secret = f"reader-{denied.split(':')[1].lower()}", "reader-secret-123"
    policy_name = f"deny-{denied.split(':')[1].lower()}"
    admin.user_add(user, secret)
    admin.policy_add(
        policy_name,
        policy=json.loads(
            session_policy(s3_model.bucket, ["s3:ListBucket", "s3:GetObject", "s3:GetBucketLocation"], [denied])
        ),
    )
    admin.attach_policy([policy_name], user=user)
    env = cli_env(s3_model, AWS_ACCESS_KEY_ID=user, AWS_SECRET_ACCESS_KEY=secret)
    result = CliRunner().invoke(main, ["model", "validate", f"s3://{s3_model.bucket}/{PREFIX}"], env=env)
    assert result.exit_code == 1
    assert result.output.startswith("ACCESS_DENIED_TO_BUCKET"), result.output
    assert result.output.count("fix:") == 1
    # The root user reads the same model: the denial is the user's policy.
    root = CliRunner().invoke(main, ["model", "validate", f"s3://{s3_model.bucket}/{PREFIX}"], env=cli_env(s3_model))
    assert root.exit_code == 0, root.output


S3_CASES = [
    "no reward_function.py",
    "no pointer at all",
    "pointer names a missing checkpoint (seed)",
    "metadata speed out of range",
]


@pytest.mark.parametrize("case", S3_CASES)
def test_broken_models_in_a_bucket_give_the_same_codes(s3_settings, tmp_path, case):
    breakage, expected = BROKEN[case]
    folder = deepracer_model(tmp_path / "model")
    breakage(folder)
    store = S3Store(s3_settings)
    prefix = f"{PREFIX}-{S3_CASES.index(case)}"  # parametrized tests share one bucket (named after the test)
    upload(folder, store, prefix)
    report = validate_model(StoreSource(store, prefix))
    assert report.codes == [expected]
    assert report.codes == validate_model(FolderSource(folder)).codes


def test_size_limits_in_a_bucket(s3_model):
    store = S3Store(s3_model)
    store.put_bytes(f"{PREFIX}/model/4_Step-162.ckpt.data-00000-of-00001", bytes(5000))
    store.put_bytes(f"{PREFIX}/metrics/TrainingMetrics.json", b'{"metrics": []}' + b" " * 200_001)
    limits = SizeLimits(checkpoint_file_bytes=4999, json_yaml_bytes=200_000, model_bytes=150_000)
    report = validate_model(StoreSource(store, PREFIX), limits)
    assert sorted(report.codes) == sorted(
        [
            Code.CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED,
            Code.JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED,
            Code.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
        ]
    )
    assert validate_model(StoreSource(store, PREFIX), SizeLimits()).ok  # the same files pass the default limits


def test_import_from_a_bucket_into_a_local_store(s3_model, tmp_path):
    store = LocalStore(tmp_path / "store")
    result = import_model(StoreSource(S3Store(s3_model), PREFIX), store, "from-s3")
    assert result.ok, (result.report.problems, result.problems)
    assert store.get_bytes("from-s3/model/.coach_checkpoint") == b"4_Step-162.ckpt"
    assert validate_model(StoreSource(store, "from-s3")).ok


def test_import_into_a_bucket_the_user_may_not_write(s3_settings, restricted_credentials, tmp_path):
    folder = deepracer_model(tmp_path / "model")
    settings = restricted_credentials(
        s3_settings.bucket,
        session_policy(s3_settings.bucket, ["s3:ListBucket", "s3:GetObject", "s3:GetBucketLocation"], ["s3:PutObject"]),
    )
    result = import_model(FolderSource(folder), S3Store(settings), "read-only")
    assert not result.ok and result.report.ok
    assert [problem.code for problem in result.problems] == [Code.S3_COPY_ERROR]
    assert result.written == ()
    assert S3Store(s3_settings).list_keys("read-only/") == []  # root credentials: nothing was written
