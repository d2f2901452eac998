"""A benchmark's work folder: gone after a good run (runs write hundreds of MB), kept after a failed one."""

from __future__ import annotations

import shutil

import pytest

from benchmarks.workdir import bench_workdir


def test_the_folder_is_removed_when_the_bench_ends_well():
    with bench_workdir("racer-test-bench-") as workdir:
        (workdir / "store").mkdir()
        (workdir / "store" / "checkpoint.bin").write_bytes(b"\0" * 1024)
        assert workdir.is_dir()
    assert not workdir.exists()


def test_a_failed_bench_keeps_its_folder_and_says_where(capsys):
    with pytest.raises(RuntimeError), bench_workdir("racer-test-bench-") as workdir:
        (workdir / "logs").mkdir()
        raise RuntimeError("the trainer stopped")
    try:
        assert (workdir / "logs").is_dir()
        assert str(workdir) in capsys.readouterr().err
    finally:
        shutil.rmtree(workdir)
