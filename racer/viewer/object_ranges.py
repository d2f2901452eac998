"""`/files` on an S3 store (MinIO in the compose deployment): HTTP Range answered with S3 GetObject's own Range, the
bytes streamed from S3 to the browser, so a video seeks without the viewer reading the whole object.

A local store needs none of this: Starlette's FileResponse answers Range itself.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

import botocore.exceptions
from starlette.exceptions import HTTPException
from starlette.responses import Response, StreamingResponse

from racer.shared.store import ObjectNotFoundError, S3Store

CHUNK_BYTES = 256 * 1024
"""Bytes per piece streamed from S3 to the browser."""

_RANGE = re.compile(r"^bytes=(\d*)-(\d*)$")


class UnsatisfiableRange(ValueError):
    """A Range that asks for no byte of the object (416)."""


def requested_range(header: str | None, size: int) -> tuple[int, int] | None:
    """The one byte range `header` asks for, inclusive (first, last), clipped to the object; None: the whole object
    (no header, a malformed one or several ranges, which a server may answer with the whole object, RFC 9110 14.2).
    Raises UnsatisfiableRange for a range that starts past the end or an empty suffix."""
    if not header:
        return None
    match = _RANGE.match(header.strip())
    if match is None:
        return None
    first_text, last_text = match.groups()
    if not first_text and not last_text:
        return None
    if not first_text:  # bytes=-N: the last N bytes
        length = int(last_text)
        if length == 0 or size == 0:
            raise UnsatisfiableRange(header)
        return max(0, size - length), size - 1
    first = int(first_text)
    last = size - 1 if not last_text else min(int(last_text), size - 1)
    if last_text and int(last_text) < first:
        return None  # an invalid range is ignored
    if first >= size:
        raise UnsatisfiableRange(header)
    return first, last


def s3_object_response(store: S3Store, key: str, media_type: str, range_header: str | None) -> Response:
    """200 with the whole object, 206 with the requested bytes (Content-Range), or 416 (Content-Range: bytes */size);
    the body streams from S3 in CHUNK_BYTES pieces. 404 for a missing object."""
    try:
        size = store.size(key)
    except ObjectNotFoundError:
        raise HTTPException(404, "no such file") from None
    headers = {"Accept-Ranges": "bytes"}
    try:
        wanted = requested_range(range_header, size)
    except UnsatisfiableRange:
        return Response(status_code=416, headers={**headers, "Content-Range": f"bytes */{size}"})
    request = {"Bucket": store.bucket, "Key": key}
    status = 200
    first, last = 0, size - 1
    if wanted is not None:
        first, last = wanted
        request["Range"] = f"bytes={first}-{last}"
        headers["Content-Range"] = f"bytes {first}-{last}/{size}"
        status = 206
    headers["Content-Length"] = str(last - first + 1)
    try:
        body = store.client.get_object(**request)["Body"] if size else None
    except (botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
        translated = store._translate(error, key, "get")
        if isinstance(translated, ObjectNotFoundError):
            raise HTTPException(404, "no such file") from None
        raise translated from error
    return StreamingResponse(_chunks(body), status_code=status, headers=headers, media_type=media_type)


def _chunks(body) -> Iterator[bytes]:
    if body is None:
        return
    try:
        yield from body.iter_chunks(CHUNK_BYTES)
    finally:
        body.close()
