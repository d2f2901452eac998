"""S3 through boto3: works against AWS S3 and MinIO (`S3_ENDPOINT_URL`)."""

from __future__ import annotations

import boto3
import botocore.config
import botocore.exceptions

from racer.shared.config import S3Settings
from racer.shared.store.base import (
    AccessDeniedError,
    BucketNotFoundError,
    ObjectNotFoundError,
    StoreUnavailableError,
    validate_key,
)


class S3Store:
    def __init__(self, settings: S3Settings):
        self.settings = settings
        self.bucket = settings.bucket
        timeout_s = max(1.0, settings.connect_timeout_s)
        self._client = boto3.client(
            "s3",
            endpoint_url=settings.endpoint_url,
            aws_access_key_id=settings.access_key_id,
            aws_secret_access_key=settings.secret_access_key,
            aws_session_token=settings.session_token,
            region_name=settings.region,
            config=botocore.config.Config(
                connect_timeout=min(3.0, timeout_s),
                read_timeout=max(10.0, timeout_s),
                retries={"max_attempts": 3, "mode": "standard"},
                s3={"addressing_style": "path"},
            ),
        )

    @property
    def client(self):
        """The boto3 client, for callers that need an S3 feature the store does not wrap."""
        return self._client

    def describe(self) -> str:
        endpoint = self.settings.endpoint_url or "AWS"
        return f"s3://{self.bucket} ({endpoint})"

    def _translate(self, error: Exception, key: str, operation: str) -> Exception:
        if isinstance(error, botocore.exceptions.EndpointConnectionError | botocore.exceptions.ConnectTimeoutError):
            return StoreUnavailableError(
                f"cannot reach S3 endpoint {self.settings.endpoint_url or 'AWS'} for {operation} of "
                f"s3://{self.bucket}/{key}: {error}. Is MinIO running and S3_ENDPOINT_URL right?"
            )
        if isinstance(error, botocore.exceptions.ClientError):
            code = error.response.get("Error", {}).get("Code", "")
            if code in {"NoSuchKey", "404", "NotFound"}:
                return ObjectNotFoundError(self.describe(), key)
            if code == "NoSuchBucket":
                return BucketNotFoundError(self.bucket, self.settings.endpoint_url or "AWS")
            if code in {"AccessDenied", "403", "InvalidAccessKeyId", "SignatureDoesNotMatch"}:
                return AccessDeniedError(self.describe(), key, operation)
        return error

    def put_bytes(self, key: str, data: bytes) -> None:
        try:
            self._client.put_object(Bucket=self.bucket, Key=validate_key(key), Body=data)
        except botocore.exceptions.BotoCoreError as error:
            raise self._translate(error, key, "put") from error
        except botocore.exceptions.ClientError as error:
            raise self._translate(error, key, "put") from error

    def get_bytes(self, key: str) -> bytes:
        try:
            response = self._client.get_object(Bucket=self.bucket, Key=validate_key(key))
            return response["Body"].read()
        except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            raise self._translate(error, key, "get") from error

    def list_keys(self, prefix: str) -> list[str]:
        keys: list[str] = []
        try:
            paginator = self._client.get_paginator("list_objects_v2")
            for page in paginator.paginate(Bucket=self.bucket, Prefix=prefix):
                keys.extend(item["Key"] for item in page.get("Contents", []))
        except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            raise self._translate(error, prefix, "list") from error
        return sorted(keys)

    def delete(self, key: str) -> None:
        try:
            self._client.delete_object(Bucket=self.bucket, Key=validate_key(key))
        except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            raise self._translate(error, key, "delete") from error

    def exists(self, key: str) -> bool:
        try:
            self._client.head_object(Bucket=self.bucket, Key=validate_key(key))
            return True
        except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            translated = self._translate(error, key, "head")
            if isinstance(translated, ObjectNotFoundError):
                return False
            raise translated from error

    def size(self, key: str) -> int:
        try:
            return int(self._client.head_object(Bucket=self.bucket, Key=validate_key(key))["ContentLength"])
        except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            raise self._translate(error, key, "head") from error

    def ensure_bucket(self) -> None:
        """Create the bucket if it is missing (used by `racer train` against a fresh MinIO)."""
        try:
            self._client.head_bucket(Bucket=self.bucket)
        except botocore.exceptions.ClientError as error:
            code = error.response.get("Error", {}).get("Code", "")
            if code not in {"404", "NoSuchBucket", "NotFound"}:
                raise self._translate(error, "", "head bucket") from error
            self._client.create_bucket(Bucket=self.bucket)
        except botocore.exceptions.BotoCoreError as error:
            raise self._translate(error, "", "head bucket") from error
