#!/usr/bin/env python3
"""Every function liblocd and liblocd_narrow export has an entry in docs/api.md (meson test 'api_docs').

    python3 scripts/check_api_docs.py docs/api.md build/lib/liblocd.so [build/lib/liblocd_narrow.so ...]

Reads the exported functions with `nm -D --defined-only` (the ' T locd_' symbols, version suffix
dropped) and fails, naming them, when one does not appear in the page as a whole word. Exit 77
(skipped) when nm is not there.
"""
import re
import shutil
import subprocess
import sys


def exported(lib):
    out = subprocess.run(["nm", "-D", "--defined-only", lib], check=True, stdout=subprocess.PIPE,
                         universal_newlines=True).stdout
    names = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] == "T" and parts[2].startswith("locd_"):
            names.add(parts[2].split("@")[0])
    return sorted(names)


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    doc, libs = sys.argv[1], sys.argv[2:]
    if not shutil.which("nm"):
        print("nm not found: skipped")
        return 77
    names = []
    for lib in libs:
        found = exported(lib)
        if not found:
            print("no locd_ function exported by %s: is it the library?" % lib)
            return 1
        names += found
    text = open(doc, encoding="utf-8").read()
    missing = [n for n in names if not re.search(r"(?<![A-Za-z0-9_])%s(?![A-Za-z0-9_])" % re.escape(n), text)]
    if missing:
        print("%d of %d exported functions are missing from %s (add each where it belongs and to the table "
              "'Every exported function'):" % (len(missing), len(names), doc))
        for n in missing:
            print("  " + n)
        return 1
    print("all %d exported functions are in %s" % (len(names), doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
