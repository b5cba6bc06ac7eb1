"""Level 3's per-job deadline from Python (issue 18 item 3): a service that
accepts the connection and the job but never answers must not block
find_pairs forever; Engine(service_timeout_ms=...) bounds it."""
import os
import socket
import struct
import tempfile
import threading
import time

import numpy as np
import pytest

import locd


class SilentService:
    """Answers HELLO with WELCOME (no shared memory), then reads and never answers."""

    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.bind(path)
        self.sock.listen(4)
        self.conns = []
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            head = conn.recv(24, socket.MSG_WAITALL)
            if len(head) < 24:
                continue
            length = struct.unpack_from("<Q", head, 16)[0]
            conn.recv(length, socket.MSG_WAITALL)  # the HELLO's secret
            conn.sendall(struct.pack("<IHHQQI", 0x5344434C, 1, 2, 0, 4, 0))  # WELCOME, shm_ok = 0

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.fixture
def silent():
    d = tempfile.mkdtemp(prefix="locd-deadline-")
    os.chmod(d, 0o700)
    path = os.path.join(d, "s.sock")
    svc = SilentService(path)
    yield "unix:" + path
    svc.close()
    os.unlink(path)
    os.rmdir(d)


def _boxes(n=200):
    rng = np.random.default_rng(1)
    lo = rng.random((n, 3), dtype=np.float32)
    return np.hstack([lo, lo + 0.05]).astype(np.float32)


def test_find_on_a_silent_service_ends_at_the_deadline(silent):
    with locd.Engine(level="service", service=silent, service_timeout_ms=400) as engine:
        t0 = time.monotonic()
        with pytest.raises(locd.WaitTimeoutError, match="deadline"):
            engine.find_pairs(_boxes())
        took = time.monotonic() - t0
        assert 0.35 < took < 3.0, took
        job = engine.submit(_boxes())
        with pytest.raises(locd.WaitTimeoutError):
            job.result()  # waits without a bound of its own
        assert time.monotonic() - t0 < 6.0


def test_service_timeout_option_is_checked():
    with pytest.raises(TypeError):
        locd.Engine(level="service", service="unix:/nonexistent", service_timeout_ms=1.5)
    with pytest.raises(ValueError):
        locd.Engine(level="service", service="unix:/nonexistent", service_timeout_ms=0)


def test_no_deadline_and_a_working_service():
    with locd.Service("unix:" + os.path.join(tempfile.mkdtemp(prefix="locd-dl-"), "s.sock"), threads=1) as svc:
        b = _boxes(300)
        want = locd.find_pairs(b, sort=True)
        for t in (None, -1, 10000):
            with locd.Engine(level="service", service=svc.address, service_timeout_ms=t) as engine:
                assert np.array_equal(engine.find_pairs(b, sort=True), want)
