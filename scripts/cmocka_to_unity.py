#!/usr/bin/env python3
"""One-off helper used to move a C test file from cmocka to Unity: rewrites the
mechanical parts in place (assertions, test signatures, the test table).
What it cannot rewrite (group setup, state pointers) is left for a person and
reported. usage: cmocka_to_unity.py FILE..."""
import re
import sys

# cmocka name -> (Unity macro, argument order): 'swap' puts cmocka's second
# argument (the expected value) first, as Unity wants.
MAP = {
    "assert_int_equal": ("TEST_ASSERT_EQUAL_INT64", "swap"),
    "assert_int_not_equal": ("TEST_ASSERT_NOT_EQUAL_INT64", "swap"),
    "assert_true": ("TEST_ASSERT_TRUE", None),
    "assert_false": ("TEST_ASSERT_FALSE", None),
    "assert_non_null": ("TEST_ASSERT_NOT_NULL", None),
    "assert_null": ("TEST_ASSERT_NULL", None),
    "assert_memory_equal": ("TEST_ASSERT_EQUAL_MEMORY", "swap"),
    "assert_string_equal": ("TEST_ASSERT_EQUAL_STRING", "swap"),
    "fail_msg": ("LT_FAIL", None),
    "print_message": ("LT_PRINT", None),
}


def split_args(s):
    depth, cur, out, q = 0, "", [], None
    for ch in s:
        if q:
            cur += ch
            if ch == q and not cur.endswith("\\" + q):
                q = None
            continue
        if ch in "\"'":
            q = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(cur)
            cur = ""
            continue
        cur += ch
    out.append(cur)
    return out


def rewrite_calls(src):
    out, i = "", 0
    pat = re.compile(r"\b(" + "|".join(MAP) + r")\s*\(")
    while True:
        m = pat.search(src, i)
        if not m:
            return out + src[i:]
        out += src[i:m.start()]
        j, depth = m.end(), 1
        while depth:
            depth += {"(": 1, ")": -1}.get(src[j], 0)
            j += 1
        args = split_args(src[m.end():j - 1])
        name, order = MAP[m.group(1)]
        if order == "swap":
            args = [args[1].strip(), args[0].strip()] + [a.strip() for a in args[2:]]
        else:
            args = [a.strip() for a in args]
        out += name + "(" + ", ".join(args) + ")"
        i = j


def convert(path):
    s = open(path).read()
    s = s.replace("#include <cmocka.h>", '#include "runner.h"')
    s = re.sub(r"\(void \*\*state\)", "(void)", s)
    s = re.sub(r"\n[ \t]*\(void\)state;", "", s)
    s = rewrite_calls(s)
    s = re.sub(r"\bskip\(\)", "TEST_IGNORE()", s)
    s = re.sub(r"cmocka_unit_test_setup_teardown\(", "LT_TEST_FIXTURE(", s)
    s = re.sub(r"cmocka_unit_test\(", "LT_TEST(", s)
    s = s.replace("const struct CMUnitTest", "static const lt_test")
    s = re.sub(r"return cmocka_run_group_tests\((\w+), NULL, NULL\);", r"return LT_RUN(\1);", s)
    open(path, "w").write(s)
    left = [l for l in s.splitlines() if re.search(r"cmocka|state\b|CMUnitTest", l)]
    for l in left:
        print(f"{path}: left for a person: {l.strip()}")


for p in sys.argv[1:]:
    convert(p)
