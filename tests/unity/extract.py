#!/usr/bin/env python3
"""Extracts the Unity C test framework (ThrowTheSwitch Unity v2.6.1) from the
PyPI wheel vyperling==0.0.4 into the build tree, after checking the wheel's
sha256. The files are never committed: scripts/setup.sh downloads the wheel
(pip --require-hashes) and Meson runs this at build time.

usage: extract.py WHEEL OUTDIR
"""
import hashlib
import os
import sys
import zipfile

SHA256 = "028f4419cf4f49cfaed51256290718753a78cc035923fbf43acc8bcd62d205cb"
FILES = ["unity.c", "unity.h", "unity_internals.h", "UNITY_LICENSE"]


def main():
    wheel, outdir = sys.argv[1], sys.argv[2]
    with open(wheel, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    if digest != SHA256:
        sys.exit(f"extract.py: {wheel}: sha256 {digest}, expected {SHA256}")
    os.makedirs(outdir, exist_ok=True)
    with zipfile.ZipFile(wheel) as z:
        for name in FILES:
            data = z.read("vyperling/c/" + name)
            with open(os.path.join(outdir, name), "wb") as out:
                out.write(data)


if __name__ == "__main__":
    main()
