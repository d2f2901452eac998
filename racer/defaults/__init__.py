"""Files racer ships with its code, so an installed racer needs no source tree.

`redis.conf` (a link to the repository's top-level `redis.conf`, the one file; the wheel carries its contents)
configures every Redis racer uses (the embedded `racer train`, the tests, docker compose) and
`custom_files/` is the example reward function, `model_metadata.json` and `hyperparameters.json` that
`racer train` uses when no `--custom-files` is given. The repository's top-level `custom_files` is a link here.
`racing/discrete/` and `racing/continuous/` are the fast-lap recipe: custom files for a fast lap (docs/racing.md says
why each value is what it is; `python -m benchmarks race-pace` trains with them).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def packaged_path(name: str) -> Path:
    """The file-system path of a file or folder in this package (redis-server and click need real paths)."""
    resource = resources.files(__name__) / name
    if not isinstance(resource, Path):
        raise FileNotFoundError(
            f"racer/defaults/{name}: racer is installed in a form without plain files ({type(resource).__name__}); "
            "install it from its wheel or source folder"
        )
    if not resource.exists():
        raise FileNotFoundError(f"racer/defaults/{name} is missing from the installed racer package ({resource})")
    return resource


REDIS_CONF = packaged_path("redis.conf")
"""The Redis configuration of every racer Redis (embedded runs bind it to loopback on their own port)."""

DEFAULT_CUSTOM_FILES = packaged_path("custom_files")
"""`racer train`'s default `--custom-files` folder."""

FAST_LAP_CUSTOM_FILES: dict[str, Path] = {
    space: packaged_path(f"racing/{space}") for space in ("discrete", "continuous")
}
"""The fast-lap recipe's custom files folders by action space type."""
