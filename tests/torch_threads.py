"""One torch thread for the tests of a folder: the two cores are shared, and single-sample work gains nothing from more.

A folder opts in by importing the fixture into its conftest.py (`from tests.torch_threads import one_torch_thread`).
"""

from __future__ import annotations

import pytest
import torch


@pytest.fixture(autouse=True)
def one_torch_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
