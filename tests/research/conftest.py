"""Study tests run torch on one thread, as the bench tests do."""

from tests.torch_threads import one_torch_thread  # noqa: F401 (an autouse fixture for this folder)
