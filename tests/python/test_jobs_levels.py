"""Asynchronous jobs and integration levels 2 (worker processes) and 3 (service) from Python.

Each group is skipped only when a runtime probe shows the C library reports
LOCD_ERR_UNSUPPORTED for it (the feature is not in this build); any other
failure fails the tests.
"""
import concurrent.futures
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np
import pytest

import locd
from conftest import REPO_ROOT, numpy_pairs, sorted_pairs, uniform_scene

UNSUPPORTED = locd.STATUS["ERR_UNSUPPORTED"]


def _unsupported(make):
    try:
        obj = make()
    except locd.Error as e:
        if e.status == UNSUPPORTED:
            return str(e)
        raise
    if hasattr(obj, "close"):
        obj.close()
    return None


def _probe_jobs():
    with locd.Engine(threads=1) as engine:
        return _unsupported(lambda: engine.submit(np.zeros((2, 6), np.float32)).result())


def _probe_workers():
    return _unsupported(lambda: locd.Engine(level="workers", workers=2))


JOBS_MISSING = _probe_jobs()
WORKERS_MISSING = _probe_workers()
needs_jobs = pytest.mark.skipif(JOBS_MISSING is not None, reason="jobs: %s" % JOBS_MISSING)
needs_workers = pytest.mark.skipif(WORKERS_MISSING is not None, reason="level workers: %s" % WORKERS_MISSING)


def scenes():
    rng = np.random.default_rng(9)
    lo = rng.random((800, 3))
    mixed = np.hstack([lo, lo + rng.random((800, 3)) ** 4 * 0.3])
    lattice = np.array([[x, y, z, x + 1, y + 1, z + 1] for x in range(6) for y in range(6) for z in range(6)],
                       dtype=np.float32)
    return [uniform_scene(3000, seed=1), mixed, mixed.astype(np.float32), lattice, np.zeros((0, 6))]


# -- jobs -----------------------------------------------------------------------------
@needs_jobs
def test_job_result_matches_find_pairs():
    with locd.Engine(threads=2) as engine:
        for boxes in scenes():
            expected = engine.find_pairs(boxes)
            job = engine.submit(boxes)
            got = job.result(timeout=60)
            np.testing.assert_array_equal(got, expected)
            assert job.done() and not job.cancelled()
            assert job.result() is got  # the result is kept
            assert job.stats.objects == len(boxes) and job.stats.pairs == len(got)
            np.testing.assert_array_equal(engine.submit(boxes, sort=True).result(), numpy_pairs(boxes))


@needs_jobs
def test_job_copies_the_boxes():
    boxes = uniform_scene(3000, seed=2)
    expected = sorted_pairs(numpy_pairs(boxes))
    with locd.Engine(threads=1) as engine:
        job = engine.submit(boxes)
        boxes[:] = np.nan  # the caller may reuse its buffer at once
        np.testing.assert_array_equal(sorted_pairs(job.result(timeout=60)), expected)


@needs_jobs
def test_job_timeout_then_result():
    boxes = uniform_scene(1_000_000, seed=3)
    with locd.Engine(threads=1) as engine:
        job = engine.submit(boxes)
        with pytest.raises(concurrent.futures.TimeoutError):
            job.result(timeout=0.001)
        assert len(job.result()) > 0 and job.done()


@needs_jobs
def test_job_cancel():
    boxes = uniform_scene(1_000_000, seed=4)
    with locd.Engine(threads=1) as engine:
        job = engine.submit(boxes)
        if job.cancel():
            with pytest.raises(concurrent.futures.CancelledError):
                job.result(timeout=60)
            assert job.done() and job.cancelled()
        else:  # it had already finished: the result stands
            assert len(job.result()) > 0
        # The engine is usable again once the cancelled run has returned.
        small = uniform_scene(100)
        np.testing.assert_array_equal(sorted_pairs(find_when_free(engine, small)), numpy_pairs(small))


def find_when_free(engine, boxes, limit=60.0):
    deadline = time.time() + limit
    while True:
        try:
            return engine.find_pairs(boxes)
        except locd.Error as e:
            if e.status != locd.STATUS["ERR_BUSY"] or time.time() > deadline:
                raise
            time.sleep(0.01)


@needs_jobs
def test_engine_is_busy_while_its_job_runs():
    boxes = uniform_scene(1_000_000, seed=6)
    with locd.Engine(threads=1) as engine:
        job = engine.submit(boxes)
        if not job.done():
            with pytest.raises(locd.Error) as info:
                engine.find_pairs(boxes[:10])
            assert info.value.status == locd.STATUS["ERR_BUSY"]
        expected = job.result(timeout=60)
        np.testing.assert_array_equal(find_when_free(engine, boxes), expected)


@needs_jobs
def test_closing_the_engine_cancels_unfinished_jobs():
    engine = locd.Engine(threads=1)
    job = engine.submit(uniform_scene(1_000_000, seed=5))
    engine.close()
    assert job.done()
    with pytest.raises(concurrent.futures.CancelledError):
        job.result()


@needs_jobs
def test_job_bad_box_raises_on_submit_or_result():
    boxes = uniform_scene(50)
    boxes[7, 2] = np.inf
    with locd.Engine(threads=1) as engine:
        try:
            job = engine.submit(boxes)
        except locd.InvalidBoxError as e:  # checked at submit
            assert e.index == 7
            return
        with pytest.raises(locd.InvalidBoxError) as info:
            job.result(timeout=60)
        assert info.value.index == 7
        assert job.done() and not job.cancelled()
        with pytest.raises(locd.InvalidBoxError):  # raised again, like a future
            job.result()


# -- level 2: worker processes --------------------------------------------------------
@needs_workers
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_workers_level_matches_inprocess(workers):
    with locd.Engine(level="workers", workers=workers) as engine, locd.Engine(threads=1) as ref:
        assert engine.level == "workers"
        for boxes in scenes():
            got = engine.find_pairs(boxes)
            np.testing.assert_array_equal(got, ref.find_pairs(boxes))  # same order too
            np.testing.assert_array_equal(sorted_pairs(got), numpy_pairs(boxes))
            assert engine.stats.pairs == len(got)
        bad = uniform_scene(40)
        bad[31, 0] = np.nan
        with pytest.raises(locd.InvalidBoxError) as info:
            engine.find_pairs(bad)
        assert info.value.index == 31


@needs_workers
@needs_jobs
def test_workers_level_jobs():
    boxes = uniform_scene(20000, seed=6)
    with locd.Engine(level="workers", workers=2) as engine:
        np.testing.assert_array_equal(engine.submit(boxes).result(timeout=120), engine.find_pairs(boxes))


# -- level 3: service -----------------------------------------------------------------
def _probe_service():
    tmp = tempfile.mkdtemp(prefix="locd-py-")
    try:
        return _unsupported(lambda: locd.Service("unix:" + os.path.join(tmp, "probe.sock"), threads=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


SERVICE_MISSING = _probe_service()
needs_service = pytest.mark.skipif(SERVICE_MISSING is not None, reason="service: %s" % SERVICE_MISSING)


def check_service_engine(engine):
    with locd.Engine(threads=1) as ref:
        assert engine.level == "service"
        for boxes in scenes():
            got = engine.find_pairs(boxes)
            np.testing.assert_array_equal(got, ref.find_pairs(boxes))  # same order too
            np.testing.assert_array_equal(sorted_pairs(got), numpy_pairs(boxes))
            assert engine.stats.pairs == len(got)
        # Many jobs in flight on one service engine.
        boxes = uniform_scene(20000, seed=8)
        jobs = [engine.submit(boxes), engine.submit(boxes.astype(np.float64), sort=True), engine.submit(boxes[:500])]
        np.testing.assert_array_equal(jobs[0].result(timeout=120), ref.find_pairs(boxes))
        np.testing.assert_array_equal(jobs[1].result(timeout=120), ref.find_pairs(boxes, sort=True))
        np.testing.assert_array_equal(jobs[2].result(timeout=120), ref.find_pairs(boxes[:500]))
        assert jobs[0].stats.objects == len(boxes)
        bad = uniform_scene(40)
        bad[12, 4] = -np.inf
        with pytest.raises(locd.InvalidBoxError) as info:
            engine.find_pairs(bad)
        assert info.value.index == 12


@needs_service
def test_service_in_process_unix_socket():
    tmp = tempfile.mkdtemp(prefix="locd-py-")
    try:
        with locd.Service("unix:" + os.path.join(tmp, "locd.sock"), threads=2) as svc:
            assert svc.address.startswith("unix:")
            with locd.Engine(level="service", service=svc.address) as engine:
                check_service_engine(engine)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@needs_service
def test_service_tcp_with_secret():
    with locd.Service("tcp:127.0.0.1:0", secret="s3cret", threads=1) as svc:
        assert svc.address.startswith("tcp:127.0.0.1:") and not svc.address.endswith(":0")
        with locd.Engine(level="service", service=svc.address, secret="s3cret") as engine:
            boxes = uniform_scene(2000, seed=12)
            np.testing.assert_array_equal(sorted_pairs(engine.find_pairs(boxes)), numpy_pairs(boxes))
        with pytest.raises(locd.Error) as info:
            with locd.Engine(level="service", service=svc.address, secret="wrong") as engine:
                engine.find_pairs(uniform_scene(10))
        assert info.value.status == locd.STATUS["ERR_AUTH"]


def _cli():
    for path in (os.environ.get("LOCD_CLI"), os.path.join(REPO_ROOT, "build-ci", "c", "tools", "locd"),
                 shutil.which("locd")):
        if path and os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    return None


@needs_service
def test_service_in_another_process():
    """`locd serve` from the C build (step 10 of CI) as a separate process."""
    cli = _cli()
    if cli is None:
        pytest.skip("no locd CLI built (set LOCD_CLI)")
    tmp = tempfile.mkdtemp(prefix="locd-py-")
    sock = os.path.join(tmp, "locd.sock")
    proc = subprocess.Popen([cli, "serve", "--listen", "unix:" + sock, "--threads", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.time() + 20
        while not os.path.exists(sock):
            if proc.poll() is not None:
                raise RuntimeError("locd serve exited with %d: %s" % (proc.returncode, proc.stdout.read()))
            if time.time() > deadline:
                raise RuntimeError("locd serve did not listen on %s" % sock)
            time.sleep(0.05)
        with locd.Engine(level="service", service="unix:" + sock) as engine:
            check_service_engine(engine)
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
        shutil.rmtree(tmp, ignore_errors=True)


def test_service_unreachable_is_locd_error():
    with pytest.raises(locd.Error) as info:
        locd.Engine(level="service", service="unix:/nonexistent/locd-test.sock")
    assert info.value.status < 0 and not isinstance(info.value, locd.InvalidBoxError)
