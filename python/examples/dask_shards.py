"""One Monte Carlo profile traced as shards on a Dask cluster and merged.

Each worker traces its shards on its own (`simulate(shard=(k, n))`); a
Profile pickles as its file's text, which round-trips every number, so the
parts reach the client unchanged and `merge` gives the single run bit for
bit. Point `Client` at your scheduler's address instead of a LocalCluster
to use a real cluster.

    python dask_shards.py marble 1e9 64 8    # material, photons, shards, workers
"""

import sys

from dask.distributed import Client, LocalCluster

import ssskit


def shard(material, photons, seed, k, n):
    return ssskit.simulate(material, photons=photons, seed=seed, shard=(k, n), threads=1)


def traced(material="marble", photons=1e9, shards=64, workers=8, seed=7):
    with LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        futures = [client.submit(shard, material, photons, seed, k, shards) for k in range(1, shards + 1)]
        parts = client.gather(futures)
    return ssskit.merge(parts)


if __name__ == "__main__":
    material, photons, shards, workers = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    traced(material, photons, shards, workers).save(f"{material}.json")
