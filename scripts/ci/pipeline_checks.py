#!/usr/bin/env python3
"""End-to-end checks of `locd simulate` on the example scenes (CI step 70-pipeline).

    pipeline_checks.py LOCD_BINARY JUNIT_OUT [--quick]

Each check is one JUnit testcase: the fast ball is caught only with continuous
detection on, the fast rock likewise on the mesh terrain, the broad-phase-only
scene spends zero calls and zero time in the other stages, filters and removal
hold (with per-step contact begin/end counts that add up), every per-step line
is JSON with a `stages` object of four stages, and frames render.
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from xml.sax.saxutils import escape, quoteattr

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = os.path.join(ROOT, "examples", "scenes")
STAGES = ("broad", "shape", "swept", "contact")
FIELDS = ("calls", "ms", "pairs_in", "pairs_out")


def simulate(locd, scene, *args):
    cmd = [locd, "simulate", os.path.join(SCENES, scene)] + list(args)
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=300).stdout
    lines = [json.loads(line) for line in out.splitlines() if line.strip()]
    steps = [d for d in lines if "step" in d]
    summary = [d["summary"] for d in lines if "summary" in d]
    if len(summary) != 1:
        raise AssertionError("expected one summary line, got %d" % len(summary))
    for d in steps:
        for st in STAGES:
            for f in FIELDS:
                if f not in d["stages"][st]:
                    raise AssertionError("step %s: stages.%s.%s missing" % (d["step"], st, f))
    return steps, summary[0]


def check(cond, msg):
    if not cond:
        raise AssertionError(msg)


def fast_ball_caught(locd):
    steps, s = simulate(locd, "falling_balls.json", "--steps", "60")
    b = s["tracked"]["fast_ball"]
    check(b["contacts"] >= 1 and b["min_z"] > 0.0, "continuous auto: fast ball not caught: %s" % b)
    check(s["stages"]["swept"]["calls"] == 60 and s["stages"]["swept"]["pairs_out"] >= 1, "swept stage idle")
    check(len(steps) == 60, "60 step lines expected")
    return "fast ball min z %.3f, %d contacts" % (b["min_z"], b["contacts"])


def fast_ball_tunnels_without_continuous(locd):
    out = []
    for scene, args in (("falling_balls.json", ["--continuous", "off"]), ("falling_balls_discrete.json", [])):
        _, s = simulate(locd, scene, "--steps", "60", "--quiet", *args)
        b = s["tracked"]["fast_ball"]
        check(b["contacts"] == 0 and b["min_z"] < -0.4, "%s %s: fast ball did not tunnel: %s" % (scene, args, b))
        check(s["stages"]["swept"]["calls"] == 0, "swept stage ran with continuous off")
        out.append("%s: min z %.1f" % (scene, b["min_z"]))
    return "; ".join(out)


def fast_rock_on_terrain(locd):
    _, on = simulate(locd, "rocks_on_terrain.json", "--steps", "90", "--quiet")
    _, off = simulate(locd, "rocks_on_terrain.json", "--steps", "30", "--quiet", "--continuous", "off")
    r_on, r_off = on["tracked"]["fast_rock"], off["tracked"]["fast_rock"]
    check(r_on["contacts"] >= 1 and r_on["min_z"] > -2.0, "fast rock not caught: %s" % r_on)
    check(r_off["contacts"] == 0 and r_off["min_z"] < -5.0, "fast rock did not tunnel without continuous: %s" % r_off)
    check(on["tests"]["ccd"] > 0 and on["tests"]["fcl"] > 0, "libccd and FCL both expected: %s" % on["tests"])
    return "caught at min z %.2f; without: %.1f" % (r_on["min_z"], r_off["min_z"])


def broad_phase_only(locd, quick):
    scene = "broadphase_million.json"
    args = ["--steps", "1" if quick else "2"]
    steps, s = simulate(locd, scene, *args)
    for d in steps:
        st = d["stages"]
        check(st["broad"]["calls"] == 1 and st["broad"]["pairs_out"] > 0, "broad stage: %s" % st["broad"])
        for other in ("shape", "swept", "contact"):
            check(st[other]["calls"] == 0 and st[other]["ms"] == 0.0 and st[other]["pairs_in"] == 0,
                  "step %d: stage %s not idle: %s" % (d["step"], other, st[other]))
        check(d["tests"] == {"closed": 0, "ccd": 0, "fcl": 0}, "pair tests ran: %s" % d["tests"])
    return "%d objects, %d pairs, broad %.0f ms/step" % (
        s["objects"], steps[0]["pairs"], s["stages"]["broad"]["ms"] / len(steps))


def box_pile(locd):
    _, s = simulate(locd, "box_pile.json", "--steps", "90", "--quiet")
    check(s["tests"]["closed"] > 0, "box-box pairs should use the closed form")
    check(s["stages"]["contact"]["pairs_out"] > 0, "boxes should touch")
    return "closed-form tests %d" % s["tests"]["closed"]


def filters_and_events(locd):
    steps, s = simulate(locd, "filtered_balls.json", "--steps", "90")
    t = s["tracked"]
    check(t["ghost"]["contacts"] == 0 and t["ghost"]["min_z"] < -1.0, "ghost (masked out) should fall through: %s" % t)
    check(t["floor"]["contacts"] > 0, "the grid balls should land on the floor")
    check(sum(d["removed"] for d in steps) == 1 and steps[59]["removed"] == 1 and steps[59]["objects"] == 50,
          "the doomed ball leaves at step 60")
    check(sum(d["began"] for d in steps) == s["contacts_began"] and
          sum(d["ended"] for d in steps) == s["contacts_ended"], "per-step began/ended add up to the summary")
    live = 0
    for d in steps:  # contacts now = contacts before + began - ended
        live += d["began"] - d["ended"]
        check(live == d["pairs"], "step %d: %d pairs, events say %d" % (d["step"], d["pairs"], live))
    return "began %d, ended %d" % (s["contacts_began"], s["contacts_ended"])


def frames_render(locd):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return None
    with tempfile.TemporaryDirectory() as d:
        simulate(locd, "falling_balls.json", "--steps", "6", "--every", "3", "--quiet", "--frames", d)
        pngs = sorted(f for f in os.listdir(d) if f.endswith(".png"))
        check(len(pngs) == 3, "expected 3 frames, got %s" % pngs)
    return "3 frames"


def main():
    locd, junit = sys.argv[1], sys.argv[2]
    quick = "--quick" in sys.argv
    checks = [
        ("fast_ball_caught_with_continuous", lambda: fast_ball_caught(locd)),
        ("fast_ball_tunnels_without_continuous", lambda: fast_ball_tunnels_without_continuous(locd)),
        ("fast_rock_on_mesh_terrain", lambda: fast_rock_on_terrain(locd)),
        ("broad_phase_only_million", lambda: broad_phase_only(locd, quick)),
        ("box_pile_closed_forms", lambda: box_pile(locd)),
        ("filters_and_contact_events", lambda: filters_and_events(locd)),
        ("frames_render", lambda: frames_render(locd)),
    ]
    cases, failures = [], 0
    for name, fn in checks:
        t0 = time.time()
        try:
            msg = fn()
            if msg is None:
                body, status = '<skipped message="matplotlib missing"/>', "skip"
            else:
                body, status = "<system-out>%s</system-out>" % escape(msg), "ok  "
        except Exception as e:  # one failing check must not hide the others
            failures += 1
            msg = "%s: %s" % (type(e).__name__, e)
            body, status = "<failure message=%s>%s</failure>" % (quoteattr(msg[:200]), escape(msg)), "FAIL"
        secs = time.time() - t0
        print("%s %s (%.1fs): %s" % (status, name, secs, msg))
        cases.append('<testcase classname="pipeline" name=%s time="%.3f">%s</testcase>' % (quoteattr(name), secs, body))
    with open(junit, "w") as f:
        f.write('<?xml version="1.0" encoding="utf-8"?>\n<testsuites><testsuite name="pipeline" tests="%d" '
                'failures="%d">%s</testsuite></testsuites>\n' % (len(cases), failures, "".join(cases)))
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
