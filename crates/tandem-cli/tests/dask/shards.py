"""Drive the shards of a tandem sweep through a real Dask engine (dask.distributed LocalCluster)
and merge them, as a user with a Dask cluster would (docs/sweeps.md).

    python shards.py TANDEM_BINARY SWEEP_FILE WORK_DIR N

Each Dask task runs one shard process (`tandem sweep FILE --shard I/N --threads 1`); the shard
folders are then joined with `tandem merge` into WORK_DIR/merged. Exit code 0 on success.
"""

import os
import subprocess
import sys

from dask.distributed import Client, LocalCluster


def run_shard(tandem, sweep, work, i, n):
    out = os.path.join(work, f"shard-{i}")
    subprocess.run(
        [tandem, "sweep", sweep, "--shard", f"{i}/{n}", "--threads", "1", "--out", out,
         "--no-figures"],
        check=True,
        capture_output=True,
    )
    return out


def main():
    tandem, sweep, work, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        futures = [client.submit(run_shard, tandem, sweep, work, i, n, pure=False)
                   for i in range(n)]
        dirs = client.gather(futures)
    subprocess.run([tandem, "merge", *dirs, "--out", os.path.join(work, "merged")], check=True)
    print(f"dask: {n} shards on a LocalCluster, merged into {os.path.join(work, 'merged')}")


if __name__ == "__main__":
    main()
