"""The article's identification grid made denser, identified in one process and in shards on a
Dask LocalCluster (docs/beyond-one-machine.md). Not a test: it prints the figures.

    target/py-venv/bin/python python/bench/dask_grid.py [--scale 100] [--workers 2] [--shards 8]

``--scale 100`` multiplies the article's two grids (3264 + 3553 candidates, the article §2.4)
by 100: about 680,000 candidates. The one-process run uses the core's own thread pool (all the
cores); each Dask worker runs with ``RAYON_NUM_THREADS=1`` so that the workers, not the pool,
share the cores. The overhead per shard is the cluster's time over the ideal one (the
one-process time shared among the workers' threads), per shard; the fixed cost of a shard is
measured apart, on the article's own grids split into many small shards.
"""

import argparse
import json
import math
import os
import pathlib
import tempfile
import time

ARTICLE = pathlib.Path(__file__).resolve().parents[2] / "data" / "article"


def _axis(lo, hi, count, log):
    """`count` values from lo to hi (log-spaced when `log`), as TOML."""
    if count == 1:
        return [lo]
    step = (math.log(hi / lo) if log else hi - lo) / (count - 1)
    values = [lo * math.exp(k * step) if log else lo + k * step for k in range(count)]
    values[-1] = hi
    return values


def scaled_article_experiment(folder, scale):
    """Write into `folder` an experiment file on the article's records (data/article) with the
    article's two grids over their ranges made `scale` times as dense (the β and b axes each
    sqrt(scale) times as many values; c12 kept at 17 values); return its path. `scale=1` keeps
    the counts of the article's grids (3264 = 24 β × 8 b × 17 c12, 3553 = 19 × 11 × 17) on
    evenly spaced axes."""
    k = math.sqrt(scale)
    first = {
        "beta_bar": _axis(25.0, 1000.0, round(24 * k), True),
        "viscous_friction_ns_per_m": _axis(50.0, 500.0, round(8 * k), False),
        "c12_m5_per_ns": _axis(1e-13, 1e-9, 17, True),
    }
    refined = {
        "beta_bar": _axis(130.0, 220.0, round(19 * k), False),
        "viscous_friction_ns_per_m": _axis(100.0, 600.0, round(11 * k), False),
        "c12_m5_per_ns": _axis(0.8e-10, 2.4e-10, 17, False),
    }

    def table(name, grid):
        rows = "\n".join(f"{axis} = {json.dumps(values)}" for axis, values in grid.items())
        return f"[{name}]\n{rows}\n"

    text = f"""# The article's grids made {scale} times as dense (python/bench/dask_grid.py)
[standstill]
record = {json.dumps(str(ARTICLE / "standstill.csv"))}

[[dataset]]
file = {json.dumps(str(ARTICLE / "identification.csv"))}
kp = 25.0
mass_kg = 10593.0
fit_end_s = 2.7

[[dataset]]
file = {json.dumps(str(ARTICLE / "validation.csv"))}
kp = 20.0
mass_kg = 10593.0
fit_end_s = 2.4

{table("grid", first)}
{table("refined_grid", refined)}"""
    path = pathlib.Path(folder) / f"article-grid-x{scale}.toml"
    path.write_text(text)
    return str(path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scale", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--shards", type=int, default=8)
    args = parser.parse_args()

    import pumpcyl
    import pumpcyl.distributed
    from distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as folder:
        experiment = scaled_article_experiment(folder, args.scale)
        start = time.perf_counter()
        one = pumpcyl.identify(experiment, allow_long_run=True)
        one_s = time.perf_counter() - start
        candidates = one.candidates_evaluated
        print(f"candidates: {candidates}")
        print(f"one process: {one_s:.2f} s ({candidates / one_s:,.0f} candidates/s)")

        os.environ["RAYON_NUM_THREADS"] = "1"  # inherited by the worker processes
        cluster = LocalCluster(
            n_workers=args.workers, threads_per_worker=1, dashboard_address=":0"
        )
        with cluster, Client(cluster) as client:
            client.run(lambda: __import__("pumpcyl"))  # the workers load the package first
            start = time.perf_counter()
            merged = pumpcyl.distributed.identify(
                experiment, client=client, shards=args.shards, allow_long_run=True
            )
            dask_s = time.perf_counter() - start
            fixed_s = _fixed_cost_per_shard(client, folder)
        same = merged.beta_bar == one.beta_bar and merged.top == one.top
        ideal_s = one_s * os.cpu_count() / min(args.workers, os.cpu_count())
        overhead = (dask_s - ideal_s) / args.shards
        print(
            f"LocalCluster of {args.workers} workers, {args.shards} shards: {dask_s:.2f} s "
            f"({candidates / dask_s:,.0f} candidates/s); shards' search time added up "
            f"{merged.seconds:.2f} s"
        )
        print(f"overhead per shard: {overhead * 1000:.0f} ms (against {ideal_s:.2f} s ideal)")
        print(f"same answer as one process: {same} (beta_bar {merged.beta_bar:.4f} bar)")
        print(
            f"fixed cost of a shard (the article's grids in 2 and in {FEW_CANDIDATES_SHARDS} "
            f"shards): {fixed_s * 1000:.0f} ms"
        )


# Shards of the article's own grids for the fixed cost of a shard: each holds about 100
# candidates, so its time is mostly what every shard costs whatever its size.
FEW_CANDIDATES_SHARDS = 64


def _fixed_cost_per_shard(client, folder):
    """The time a shard costs beyond its candidates (s): the article's grids identified in
    2 and in FEW_CANDIDATES_SHARDS shards, the difference per added shard (best of 3)."""
    import pumpcyl.distributed

    experiment = scaled_article_experiment(folder, 1)

    def seconds(shards):
        def once():
            start = time.perf_counter()
            pumpcyl.distributed.identify(experiment, client=client, shards=shards)
            return time.perf_counter() - start

        return min(once() for _ in range(3))

    return (seconds(FEW_CANDIDATES_SHARDS) - seconds(2)) / (FEW_CANDIDATES_SHARDS - 2)


if __name__ == "__main__":
    main()
