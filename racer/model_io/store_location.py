"""The `--store` option of the model commands: a folder or s3://bucket, else RACER_STORE."""

from __future__ import annotations

import os

import click

from racer.shared.config import parse_store_location, settings_from_env
from racer.shared.store import ObjectStore, open_store


def open_store_option(location: str | None) -> ObjectStore:
    """The store `--store LOCATION` names (endpoint and keys of s3:// from the environment); RACER_STORE without it."""
    settings = settings_from_env()
    if location is None:
        return open_store(settings.store)
    try:
        return open_store(parse_store_location(location, os.environ, settings.redis.connect_timeout_s))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--store") from None
