"""rtu.sweep_on: a sweep's shards run on a concurrent.futures.Executor whose workers are other processes (a
ProcessPoolExecutor, and a real Dask LocalCluster of 2 worker processes, started and closed here) give the
DataFrame rtu.sweep gives for the whole grid in one process, apart from the wall time; a task that fails is named.
ctest runs it with the module tests (label python)."""

import logging
import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

import pandas as pd
import pytest

import rtu

# A grid no CLI sweep can list (a configuration with a changed key), of 12 points, so that shards hold 3, 4 or
# more points each and their rows must be put back in the grid's order.
GRID = dict(scenes=["builtin:cornell", "builtin:seed"], formats=["default", "compact"], bvh_widths=[4],
            configs=["rdna2", "rdna2:box_units=2", "intel"])
RUN = dict(rays=300, image_width=0)


@pytest.fixture(scope="module")
def reference():
    """The whole grid in this process."""
    df = rtu.sweep(**GRID, **RUN)
    assert len(df) == 12
    return df


@pytest.fixture(scope="module", autouse=True)
def workers_import_rtu():
    """Worker processes import rtu by name: PYTHONPATH must name the folder this rtu came from (ctest sets it;
    this makes a run by hand work too)."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(rtu.__file__)))
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([here] + ([old] if old else []))
    yield
    if old is None:
        del os.environ["PYTHONPATH"]
    else:
        os.environ["PYTHONPATH"] = old


def same_but_seconds(df, ref):
    assert list(df.columns) == list(ref.columns)
    assert (df["seconds"] > 0).all()  # measured on the workers, not copied
    pd.testing.assert_frame_equal(df.drop(columns="seconds"), ref.drop(columns="seconds"), check_exact=True)


@pytest.mark.parametrize("shards", [1, 3, 5, None])
def test_a_process_pool_gives_the_whole_sweep(reference, shards):
    with ProcessPoolExecutor(max_workers=2) as ex:
        df = rtu.sweep_on(ex, **GRID, **RUN, shards=shards)
    same_but_seconds(df, reference)


# Debian's tornado warns inside distributed 2022.12's LocalCluster; not this module's.
@pytest.mark.filterwarnings("ignore:make_current is deprecated:DeprecationWarning")
def test_a_dask_cluster_of_worker_processes_gives_the_whole_sweep(reference):
    distributed = pytest.importorskip("distributed")  # Debian's python3-distributed (scripts/setup.sh)
    with distributed.LocalCluster(processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None,
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(2, timeout=60)
        pids = client.run(os.getpid)
        assert len(pids) == 2 and os.getpid() not in pids.values()
        df = rtu.sweep_on(client.get_executor(), **GRID, **RUN, shards=4)
        # The shards ran in the worker processes: rtu was imported there (it is not before a task needs it).
        imported = client.run(lambda: "rtu" in sys.modules)
        assert any(imported.values()), imported
    same_but_seconds(df, reference)


RTUSIM = os.environ.get("RTUSIM", os.path.join(os.path.dirname(__file__), "../../build/default/rtusim"))


def dask_cluster():
    distributed = pytest.importorskip("distributed")  # Debian's python3-distributed (scripts/setup.sh)
    cluster = distributed.LocalCluster(processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None,
                                       silence_logs=logging.ERROR)
    return cluster, distributed.Client(cluster)


@pytest.mark.filterwarnings("ignore:make_current is deprecated:DeprecationWarning")
def test_a_dask_sweep_into_a_folder_collects_as_rtusim_does(reference, tmp_path):
    """With results=DIR the Dask workers write one point file each under DIR/points; the table collected equals
    the whole grid's, and rtusim sweep --manifest/--collect on the same grid makes the same manifest and, from
    the Dask folder, byte for byte the same CSV."""
    folder = tmp_path / "dask"
    cluster, client = dask_cluster()
    with cluster, client:
        client.wait_for_workers(2, timeout=60)
        df = rtu.sweep_on(client.get_executor(), **GRID, **RUN, shards=4, results=folder)
    same_but_seconds(df, reference)  # the grid's order is the manifest's: every point differs here
    assert len(list((folder / "points").glob("*.json"))) == 12
    # The manifest rtusim writes for the same grid (--set spells the changed key) is the one rtu wrote.
    run = [RTUSIM, "sweep"]
    grid = ["--scene", "builtin:cornell", "--scene", "builtin:seed", "--formats", "default,compact",
            "--bvh-width", "4", "--config", "rdna2,intel", "--rays", "300", "--image-width", "0"]
    subprocess.run([*run, *grid, "--write-manifest", tmp_path / "cli.txt"], check=True, capture_output=True)
    cli = (tmp_path / "cli.txt").read_text().splitlines()
    ours = (folder / "manifest.txt").read_text().splitlines()
    assert cli[:4] == ours[:4] and set(cli[4:]) < set(ours[4:]) and len(cli) == 12 and len(ours) == 16
    subprocess.run([*run, "--collect", folder / "points", "--manifest", folder / "manifest.txt", "--out",
                    tmp_path / "cli.csv"], check=True, capture_output=True)
    assert (tmp_path / "cli.csv").read_bytes() == (folder / "sweep.csv").read_bytes()
    prov = pd.read_csv(str(folder / "sweep.csv.provenance.csv"), dtype={"model": str})  # a hash may be all digits
    assert list(prov.columns) == ["key", "version", "model", "host", "threads", "seconds"] and len(prov) == 12
    assert (prov["model"] == ours[2].split("\t")[1]).all()  # the build that wrote the manifest made every point
    # A rerun finds every point's file: nothing runs again (the files are untouched), the same table.
    stamps = {p.name: p.stat().st_mtime_ns for p in (folder / "points").iterdir()}
    with ProcessPoolExecutor(max_workers=2) as ex:
        again = rtu.sweep_on(ex, **GRID, **RUN, shards=3, results=folder)
    assert stamps == {p.name: p.stat().st_mtime_ns for p in (folder / "points").iterdir()}
    pd.testing.assert_frame_equal(again, df, check_exact=True)
    pd.testing.assert_frame_equal(rtu.collect(folder, out=tmp_path / "again.csv"), df, check_exact=True)


def test_a_folder_holds_one_sweep(tmp_path):
    with ProcessPoolExecutor(max_workers=1) as ex:
        rtu.sweep_on(ex, "builtin:cornell", **RUN, results=tmp_path)
        with pytest.raises(rtu.Error, match="manifest.txt lists other points"):
            rtu.sweep_on(ex, "builtin:cornell", configs=["intel"], **RUN, results=tmp_path)
    manifest = (tmp_path / "manifest.txt").read_bytes()
    point = tmp_path / "points" / os.listdir(tmp_path / "points")[0]
    for out in (tmp_path / "manifest.txt", point):  # collect's output over one of its inputs: refused, untouched
        with pytest.raises(rtu.Error, match="would overwrite the sweep's manifest or point files"):
            rtu.collect(tmp_path, out=out)
    assert (tmp_path / "manifest.txt").read_bytes() == manifest and point.stat().st_size > 0
    point.unlink()
    with pytest.raises(rtu.Error, match=r"1 of 1 points have no file in .*points"):
        rtu.collect(tmp_path)


def test_concurrent_calls_into_one_folder_each_get_their_own_grid_or_a_refusal(tmp_path):
    """Three callers with three grids start rtu.sweep_on into one fresh results folder at once (a barrier), in each
    of 10 trials. Whatever the interleaving, exactly one of them creates the folder's manifest and gets its own
    grid's table; the two others are refused before any of their points runs, and none gets another's rows."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    configs = ["rdna2", "intel", "rdna2:box_units=2"]
    for trial in range(10):
        folder = tmp_path / f"trial{trial}"
        start = threading.Barrier(len(configs))
        outcome = {}

        def call(config):
            start.wait()
            try:
                with ThreadPoolExecutor(max_workers=1) as ex:
                    df = rtu.sweep_on(ex, "builtin:cornell", configs=[config], rays=50, image_width=0,
                                      results=folder)
                outcome[config] = list(df["config"])
            except Exception as e:  # an error of another kind than rtu.Error fails the verdict below
                outcome[config] = e

        callers = [threading.Thread(target=call, args=(c,)) for c in configs]
        for t in callers:
            t.start()
        for t in callers:
            t.join()
        won = [c for c, got in outcome.items() if isinstance(got, list)]
        assert len(won) == 1, (trial, outcome)
        assert outcome[won[0]] == [won[0]], (trial, outcome)  # its own grid's row, not another caller's
        for c in configs:
            if c != won[0]:
                assert isinstance(outcome[c], rtu.Error) and "lists other points" in str(outcome[c]), (trial, outcome)
        assert len(os.listdir(folder / "points")) == 1  # the refused callers ran nothing


def test_a_failed_shard_is_named(tmp_path):
    # The second scene's file is missing: check_sweep_grid does not load scenes, so its shard fails on the worker.
    missing = tmp_path / "gone.obj"
    with ProcessPoolExecutor(max_workers=2) as ex:
        with pytest.raises(rtu.Error, match=r"sweep_on: shard 2/2 failed: .*gone\.obj") as e:
            rtu.sweep_on(ex, ["builtin:cornell", str(missing)], **RUN)
    assert isinstance(e.value.__cause__, Exception)


def test_bad_shards_are_refused():
    with ProcessPoolExecutor(max_workers=1) as ex:
        with pytest.raises(rtu.Error, match="shards: expected at least 1, got 0"):
            rtu.sweep_on(ex, "builtin:cornell", shards=0, **RUN)
        with pytest.raises(TypeError, match="shards: expected an int"):
            rtu.sweep_on(ex, "builtin:cornell", shards=2.5, **RUN)
    for bad in ("0/2", "3/2", (1,), "x/y", "1-2"):
        with pytest.raises(rtu.Error, match="shard: expected"):
            rtu.sweep("builtin:cornell", shard=bad, **RUN)


def test_a_shard_of_rtu_sweep_is_every_nth_point(reference):
    """rtu.sweep(shard=(k, N)) selects the points rtusim sweep --shard k/N selects: every N-th of the grid's order,
    from the k-th."""
    for k in (1, 2, 5):
        df = rtu.sweep(**GRID, **RUN, shard=(k, 5))
        same_but_seconds(df.reset_index(drop=True), reference.iloc[k - 1::5].reset_index(drop=True))
