#!/usr/bin/env python3
"""JUnit helpers for scripts/test.sh.

junit.py step NAME passed|failed SECONDS LOG   -> a one-testcase JUnit file for a CI step
junit.py case SUITE NAME passed|failed [MSG]    -> a one-testcase JUnit file (for checks run by a step)
junit.py summary DIR                            -> counts every testcase of DIR/*.xml, prints
                                                   "N passed, N failed, N skipped"; exit 1 if any failed
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET
from xml.sax.saxutils import escape, quoteattr


def one_case(suite, name, ok, secs=0.0, message=""):
    body = "" if ok else "<failure message=%s>%s</failure>" % (quoteattr(message[:200]), escape(message))
    return ('<?xml version="1.0" encoding="utf-8"?>\n<testsuites><testsuite name=%s tests="1" failures="%d">'
            '<testcase classname=%s name=%s time="%s">%s</testcase></testsuite></testsuites>\n'
            % (quoteattr(suite), 0 if ok else 1, quoteattr(suite), quoteattr(name), secs, body))


def summary(d):
    passed = failed = skipped = 0
    for path in sorted(glob.glob(os.path.join(d, "*.xml"))):
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as e:
            print("unreadable JUnit file %s: %s" % (path, e))
            failed += 1
            continue
        for case in root.iter("testcase"):
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                print("FAILED: %s :: %s (%s)" % (case.get("classname"), case.get("name"), os.path.basename(path)))
            elif case.find("skipped") is not None:
                skipped += 1
            else:
                passed += 1
    print("%d passed, %d failed, %d skipped" % (passed, failed, skipped))
    return 1 if failed or passed == 0 else 0


def main(argv):
    if len(argv) >= 2 and argv[1] == "summary":
        return summary(argv[2])
    if len(argv) >= 5 and argv[1] == "step":
        name, status, secs = argv[2], argv[3], argv[4]
        tail = ""
        if status != "passed" and len(argv) > 5 and os.path.exists(argv[5]):
            with open(argv[5], errors="replace") as f:
                tail = "".join(f.readlines()[-40:])
        sys.stdout.write(one_case("ci-steps", name, status == "passed", secs, tail))
        return 0
    if len(argv) >= 5 and argv[1] == "case":
        sys.stdout.write(one_case(argv[2], argv[3], argv[4] == "passed", 0.0, " ".join(argv[5:])))
        return 0
    sys.stderr.write(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
