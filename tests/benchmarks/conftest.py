"""Bench tests run torch on one thread."""

from tests.torch_threads import one_torch_thread  # noqa: F401 (an autouse fixture for this folder)
