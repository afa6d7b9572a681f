"""A sweep from Python on a Dask cluster of 2 worker processes (started and closed here) into a results folder:
rtu.sweep_on(results=FOLDER) over the grid the Slurm test sweeps (builtin:cornell, formats default and compact,
BVH widths 2, 4 and 8, rdna2, 500 rays, no render).

  PYTHONPATH=BUILD/python dask_sweep.py FOLDER"""
import logging
import sys
import warnings

if __name__ == "__main__":  # the workers are spawned processes that import this file: they must not run it
    warnings.filterwarnings("ignore", category=DeprecationWarning)  # Debian's tornado inside distributed 2022.12
    import distributed

    import rtu

    with distributed.LocalCluster(processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None,
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(2, timeout=60)
        df = rtu.sweep_on(client.get_executor(), ["builtin:cornell"], ["default", "compact"], [2, 4, 8], ["rdna2"],
                          rays=500, image_width=0, shards=3, results=sys.argv[1])
    print(f"dask_sweep: {len(df)} points collected in {sys.argv[1]}/sweep.csv")
