#!/usr/bin/env python3
"""docs/benchmarks.md is what `bench/run --report-only` makes of bench/results/ (meson test 'benchmarks_doc').

    python3 scripts/check_benchmarks_doc.py SOURCE_ROOT

The page is generated: a note written into it by hand is lost the next time anyone regenerates it,
and its figures then have no source in the repository. This regenerates the page into a temporary
directory (plots included, so nothing in the tree changes) and fails, with the first differing lines,
when it is not the committed page byte for byte. Fix: put the text into bench/results/ (the notes
files bench/run includes) or into bench/run, then `bench/run --report-only`.
"""
import difflib
import subprocess
import sys
import tempfile
from pathlib import Path


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    root = Path(sys.argv[1])
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "benchmarks.md"
        r = subprocess.run([sys.executable, str(root / "bench" / "run"), "--report-only", "--docs", str(out)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
        if r.returncode != 0 or not out.exists():
            print("bench/run --report-only failed (exit %d):\n%s" % (r.returncode, r.stdout[-3000:]))
            return 1
        want, got = (root / "docs" / "benchmarks.md").read_text(), out.read_text()
    if want == got:
        print("docs/benchmarks.md is bench/run's report of bench/results/, byte for byte")
        return 0
    diff = difflib.unified_diff(want.splitlines(), got.splitlines(), "docs/benchmarks.md (committed)",
                                "bench/run --report-only", lineterm="", n=1)
    print("docs/benchmarks.md differs from what bench/run --report-only makes of bench/results/:")
    for k, line in enumerate(diff):
        if k == 60:
            print("...")
            break
        print(line)
    return 1


if __name__ == "__main__":
    sys.exit(main())
