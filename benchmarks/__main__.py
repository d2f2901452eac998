"""`python -m benchmarks NAME [OPTIONS]`, from the repository's root: every benchmark of racer."""

from benchmarks import bench_group

if __name__ == "__main__":
    bench_group(prog_name="python -m benchmarks")
