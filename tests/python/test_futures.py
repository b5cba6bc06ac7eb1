"""locd.Job is a real concurrent.futures.Future: as_completed, wait, asyncio, callbacks, cancel.

Levels 1 (threads in this process) and 3 (an in-process locd.Service on a
Unix socket); skipped only when the library reports LOCD_ERR_UNSUPPORTED.
"""
import asyncio
import concurrent.futures
import os
import shutil
import tempfile
import threading
import time

import numpy as np
import pytest

import locd
from conftest import numpy_pairs, sorted_pairs, uniform_scene
from test_jobs_levels import JOBS_MISSING, SERVICE_MISSING

pytestmark = pytest.mark.skipif(JOBS_MISSING is not None, reason="jobs: %s" % JOBS_MISSING)


def waiter_threads():
    return [t for t in threading.enumerate() if t.name == "locd-job-waiter"]


def no_waiters_left(limit=10.0):
    """The waiter threads end with their jobs (they may need a moment to return after setting the result)."""
    deadline = time.time() + limit
    while waiter_threads() and time.time() < deadline:
        time.sleep(0.01)
    return not waiter_threads()


@pytest.fixture(params=["inprocess", "service"])
def engine(request):
    if request.param == "inprocess":
        with locd.Engine(threads=2) as e:
            yield e
        return
    if SERVICE_MISSING is not None:
        pytest.skip("service: %s" % SERVICE_MISSING)
    tmp = tempfile.mkdtemp(prefix="locd-fut-")
    try:
        with locd.Service("unix:" + os.path.join(tmp, "s.sock"), threads=2) as svc:
            with locd.Engine(level="service", service=svc.address) as e:
                yield e
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def scenes(k):
    return [uniform_scene(200 + 150 * i, seed=i) for i in range(k)]


def test_job_is_a_future():
    with locd.Engine(threads=1) as e:
        job = e.submit(uniform_scene(100))
        assert isinstance(job, concurrent.futures.Future)
        job.result(60)


def test_as_completed_many_jobs(engine):
    boxes = scenes(24)
    jobs = {engine.submit(b, sort=True): k for k, b in enumerate(boxes)}
    seen = set()
    for job in concurrent.futures.as_completed(jobs, timeout=120):
        k = jobs[job]
        np.testing.assert_array_equal(job.result(), numpy_pairs(boxes[k]))
        seen.add(k)
    assert seen == set(range(len(boxes)))
    assert no_waiters_left()


def test_wait_all_and_first_completed(engine):
    boxes = scenes(8)
    jobs = [engine.submit(b) for b in boxes]
    done, _ = concurrent.futures.wait(jobs, timeout=120, return_when=concurrent.futures.FIRST_COMPLETED)
    assert done
    done, not_done = concurrent.futures.wait(jobs, timeout=120)
    assert not not_done and len(done) == len(jobs)
    for b, job in zip(boxes, jobs):
        np.testing.assert_array_equal(sorted_pairs(job.result()), numpy_pairs(b))
        assert job.exception() is None and job.done() and not job.running()


def test_asyncio_wrap_future(engine):
    boxes = scenes(6)

    async def main():
        futs = [asyncio.wrap_future(engine.submit(b, sort=True)) for b in boxes]
        return await asyncio.wait_for(asyncio.gather(*futs), 120)

    results = asyncio.run(main())
    for b, r in zip(boxes, results):
        np.testing.assert_array_equal(r, numpy_pairs(b))


def test_add_done_callback(engine):
    fired = []
    ev = threading.Event()
    job = engine.submit(uniform_scene(3000), index_dtype=np.int64)

    def cb(f):
        fired.append(f)
        ev.set()

    job.add_done_callback(cb)
    assert ev.wait(120) and fired == [job]
    assert job.result().dtype == np.int64
    late = []
    job.add_done_callback(late.append)  # already done: runs at once
    assert late == [job]


def test_result_timeout_then_result():
    with locd.Engine(threads=1) as e:
        job = e.submit(uniform_scene(1_000_000, seed=3))
        if not job.done():
            with pytest.raises(concurrent.futures.TimeoutError):
                job.result(timeout=0.001)
            with pytest.raises(concurrent.futures.TimeoutError):
                job.exception(timeout=0.001)
        assert len(job.result(120)) > 0


def test_exception_of_a_failed_job():
    bad = uniform_scene(50)
    bad[7, 2] = np.inf
    with locd.Engine(threads=1) as e:
        try:
            job = e.submit(bad)
        except locd.InvalidBoxError:
            pytest.skip("checked at submit in this build")
        exc = job.exception(60)
        assert isinstance(exc, locd.InvalidBoxError) and exc.index == 7
        with pytest.raises(locd.InvalidBoxError):
            job.result()
        assert [f.exception() is exc for f in concurrent.futures.as_completed([job])] == [True]


def test_cancel_maps_to_locd_job_cancel_and_wakes_as_completed():
    with locd.Engine(threads=1) as e:
        first = e.submit(uniform_scene(1_000_000, seed=4))
        queued = e.submit(uniform_scene(1_000_000, seed=5))  # waits behind the first (level 1 queues)
        assert queued.cancel()  # cannot have finished: the first is still running, or only just done
        assert queued.cancelled() and queued.done()
        with pytest.raises(concurrent.futures.CancelledError):
            queued.result()
        with pytest.raises(concurrent.futures.CancelledError):
            queued.exception()
        assert queued.cancel()  # again: still True, like a Future
        got = list(concurrent.futures.as_completed([queued, first], timeout=120))
        assert set(got) == {queued, first}
        assert first.cancelled() or len(first.result()) > 0
    assert no_waiters_left()


def test_asyncio_cancel_cancels_the_job():
    with locd.Engine(threads=1) as e:
        e.submit(uniform_scene(1_000_000, seed=4))  # keeps the engine busy
        job = e.submit(uniform_scene(1_000_000, seed=5))

        async def main():
            fut = asyncio.wrap_future(job)
            await asyncio.sleep(0)
            fut.cancel()
            try:
                await fut
            except asyncio.CancelledError:
                return True
            return False

        assert asyncio.run(main())
        deadline = time.time() + 10
        while not job.done() and time.time() < deadline:
            time.sleep(0.01)
        assert job.cancelled()


def test_finished_job_cannot_be_cancelled():
    with locd.Engine(threads=1) as e:
        job = e.submit(uniform_scene(100))
        job.result(60)
        assert not job.cancel() and not job.cancelled()


def test_closing_the_engine_settles_every_job():
    e = locd.Engine(threads=1)
    jobs = [e.submit(uniform_scene(300_000, seed=s)) for s in range(4)]
    e.close()
    for job in jobs:
        assert job.done()
        assert job.cancelled() or job.exception() is None
    assert no_waiters_left()


def test_no_thread_leak_after_many_jobs():
    before = threading.active_count()
    with locd.Engine(threads=1) as e:
        jobs = [e.submit(uniform_scene(200, seed=s)) for s in range(50)]
        concurrent.futures.wait(jobs, timeout=120)
        assert all(j.done() for j in jobs)
    assert no_waiters_left()
    assert threading.active_count() <= before
