"""The `--store` option of the model commands: a folder or s3://bucket, else RACER_STORE."""

from __future__ import annotations

import click

from racer.shared.config import settings_from_env, store_settings_at
from racer.shared.store import ObjectStore, open_store


def open_store_option(location: str | None) -> ObjectStore:
    """The store `--store LOCATION` names (endpoint and keys of s3:// from the environment); RACER_STORE without it."""
    if location is None:
        return open_store(settings_from_env().store)
    try:
        return open_store(store_settings_at(location))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--store") from None
