#!/usr/bin/env python3
"""Writes the seed inputs of the service harness (tests/fuzz/fuzz_service.c)
into tests/fuzz/corpus/service/: valid conversations and edge cases of the
wire protocol (lib/service/service.h). Each file is one byte choosing the
service (0: no secret, 1: secret FUZZ_SECRET) followed by the client's
bytes. Run it again after a protocol change; CI replays the corpus."""
import os
import struct
import sys

MAGIC = 0x5344434C
HELLO, WELCOME, SUBMIT, CANCEL, RESULT, ERROR = 1, 2, 3, 4, 5, 6
SECRET = b"fuzz-secret-0123456789abcdef"
SEGMENT = b"/locd-fuzz-segment"  # 4 float boxes, offered by the harness


def header(typ, ident, length, magic=MAGIC, version=1):
    return struct.pack("<IHHQQ", magic, version, typ, ident, length)


def msg(typ, ident, payload=b""):
    return header(typ, ident, len(payload)) + payload


def hello(secret=b""):
    return msg(HELLO, 0, struct.pack("<I", len(secret)) + secret)


def submit_fixed(n, f64=0, transport=0, flags=0, max_depth=0, cell_bias=0, config_flags=0):
    return struct.pack("<IIQIiIII", flags, f64, n, max_depth, cell_bias, config_flags, transport, 0)


def boxes(values, f64=0):
    return struct.pack("<%d%s" % (len(values), "d" if f64 else "f"), *values)


def submit(ident, values, f64=0, **kw):
    n = len(values) // 6
    return msg(SUBMIT, ident, submit_fixed(n, f64, **kw) + boxes(values, f64))


def submit_shm(ident, name, n, f64=0, **kw):
    return msg(SUBMIT, ident, submit_fixed(n, f64, transport=1, **kw) + struct.pack("<I", len(name)) + name)


THREE = [0, 0, 0, 1, 1, 1, 0.5, 0.5, 0.5, 2, 2, 2, 1, 1, 1, 3, 3, 3]
TOUCH = [0, 0, 0, 1, 1, 1, 1, 0, 0, 2, 1, 1]
NAN = float("nan")
INF = float("inf")

SEEDS = {
    # valid conversations
    "hello-only": b"\0" + hello(),
    "submit-f32": b"\0" + hello() + submit(1, THREE),
    "submit-f64": b"\0" + hello() + submit(7, TOUCH, f64=1),
    "submit-empty": b"\0" + hello() + submit(2, []),
    "submit-two-cancel": b"\0" + hello() + submit(1, THREE) + submit(2, TOUCH) + msg(CANCEL, 2),
    "cancel-unknown": b"\0" + hello() + msg(CANCEL, 99),
    "submit-config": b"\0" + hello() + submit(3, THREE, max_depth=4, cell_bias=-2, config_flags=1, flags=1),
    "submit-shm": b"\0" + hello() + submit_shm(4, SEGMENT, 4),
    "submit-shm-f64": b"\0" + hello() + submit_shm(5, SEGMENT, 2, f64=1),
    "secret-ok": b"\1" + hello(SECRET) + submit(1, THREE),
    "many-jobs": b"\0" + hello() + b"".join(submit(i, TOUCH) for i in range(12)),
    # bad input the service must refuse without harm
    "secret-wrong": b"\1" + hello(b"fuzz-secret-0123456789abcdeX") + submit(1, THREE),
    "secret-missing": b"\1" + hello() + submit(1, THREE),
    "hello-bad-length": b"\0" + header(HELLO, 0, 8) + struct.pack("<II", 100, 0),
    "hello-too-long": b"\0" + header(HELLO, 0, 5000),
    "submit-before-hello": b"\0" + submit(1, THREE),
    "bad-magic": b"\0" + hello() + header(SUBMIT, 1, 0, magic=0x12345678),
    "bad-version": b"\0" + hello() + header(SUBMIT, 1, 0, version=2),
    "bad-type": b"\0" + hello() + header(9, 1, 0),
    "server-type": b"\0" + hello() + msg(RESULT, 1, b"\0" * 16),
    "truncated-header": b"\0" + hello() + header(SUBMIT, 1, 36)[:13],
    "truncated-payload": b"\0" + hello() + submit(1, THREE)[:50],
    "oversized-length": b"\0" + hello() + header(SUBMIT, 1, 1 << 62),
    "short-submit": b"\0" + hello() + msg(SUBMIT, 1, b"\0" * 20),
    "submit-length-lies": b"\0" + hello() + msg(SUBMIT, 1, submit_fixed(5) + boxes(TOUCH)),
    "submit-n-huge": b"\0" + hello() + msg(SUBMIT, 1, submit_fixed(1 << 40)),
    "submit-bad-f64": b"\0" + hello() + msg(SUBMIT, 1, submit_fixed(0, f64=2)),
    "submit-bad-transport": b"\0" + hello() + msg(SUBMIT, 1, submit_fixed(0, transport=7)),
    "cancel-with-payload": b"\0" + hello() + msg(CANCEL, 1, b"x"),
    "boxes-nan-inverted": b"\0" + hello() + submit(1, [NAN, 0, 0, 1, 1, 1, 2, 2, 2, 1, 1, 1, 0, 0, 0, INF, 1, 1]),
    "shm-bad-name": b"\0" + hello() + submit_shm(1, b"/etc/passwd", 1),
    "shm-no-segment": b"\0" + hello() + submit_shm(1, b"/locd-no-such-segment", 1),
    "shm-wrong-size": b"\0" + hello() + submit_shm(1, SEGMENT, 3),
    "shm-name-long": b"\0" + hello() + submit_shm(1, b"/locd-" + b"a" * 70, 1),
}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus", "service")
    os.makedirs(out, exist_ok=True)
    for name, data in SEEDS.items():
        with open(os.path.join(out, "seed-" + name), "wb") as f:
            f.write(data)
    print("%d seeds in %s" % (len(SEEDS), out))


if __name__ == "__main__":
    main()
