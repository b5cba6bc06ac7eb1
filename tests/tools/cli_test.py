#!/usr/bin/env python3
"""The locd CLI's input and output formats (docs/formats.md), run by `meson test` (test 'cli').

    python3 tests/tools/cli_test.py BUILD/tools/locd SOURCE_ROOT

.npy input (float32/float64 (n, 6), C order, little-endian; anything else refused with its reason),
`-` for stdin (scene) and stdout (pairs file), --against (two sets), --check's 100,000-box limit,
`locd accuracy` writing into the current directory, `locd simulate --gif` finding its installed
renderer, and progress on stderr only when stderr is a terminal. Prints TAP. Needs no numpy: the
.npy files are written byte by byte.
"""
import json
import os
import pty
import shutil
import struct
import subprocess
import sys
import tempfile
import time

LOCD, ROOT = os.path.abspath(sys.argv[1]), sys.argv[2]
RESULTS = []


def test(fn):
    RESULTS.append(fn)
    return fn


def run(args, **kw):
    kw.setdefault("stdout", subprocess.PIPE)
    kw.setdefault("stderr", subprocess.PIPE)
    return subprocess.run([LOCD] + args, **kw)


def pairs(args, **kw):
    return run(["pairs"] + args, **kw)


def npy_bytes(rows, descr="<f4", fortran=False, shape=None, version=1):
    """A .npy file of the given rows (lists of 6 numbers) with the given header fields."""
    fmt = {"<f4": "<f", "<f8": "<d", ">f4": ">f", "<i4": "<i"}[descr]
    data = b"".join(struct.pack(fmt, v) for row in rows for v in row)
    shape = shape if shape is not None else (len(rows), 6)
    header = "{'descr': '%s', 'fortran_order': %s, 'shape': (%s), }" % (
        descr, "True" if fortran else "False", ", ".join(str(d) for d in shape) + ("," if len(shape) == 1 else ""))
    lead = 10 if version == 1 else 12
    pad = 64 - (lead + len(header) + 1) % 64
    header = header + " " * pad + "\n"
    size = struct.pack("<H", len(header)) if version == 1 else struct.pack("<I", len(header))
    return b"\x93NUMPY" + bytes([version, 0]) + size + header.encode() + data


def read_aabb(path):
    raw = open(path, "rb").read()
    vals = struct.unpack("<%df" % (len(raw) // 4), raw)
    return [vals[i:i + 6] for i in range(0, len(vals), 6)]


def brute(a, b=None):
    """Every overlapping pair: i < j in one set, or (i in a, j in b), sorted."""
    out = []
    for i, x in enumerate(a):
        for j, y in (enumerate(b) if b is not None else ((j, a[j]) for j in range(i + 1, len(a)))):
            if all(x[k] <= y[k + 3] and y[k] <= x[k + 3] for k in range(3)):
                out.append((i, j))
    return out


def pairs_of(raw):
    vals = struct.unpack("<%dI" % (len(raw) // 4), raw)
    return [(vals[k], vals[k + 1]) for k in range(0, len(vals), 2)]


class Tmp:
    def __enter__(self):
        self.dir = tempfile.mkdtemp(prefix="locd-cli-test-")
        return self

    def __exit__(self, *exc):
        shutil.rmtree(self.dir)

    def path(self, name):
        return os.path.join(self.dir, name)

    def gen(self, n, seed, name="s.aabb"):
        p = self.path(name)
        subprocess.run([LOCD, "gen", "uniform", str(n), "--seed", str(seed), "-o", p], check=True,
                       stdout=subprocess.DEVNULL)
        return p


@test
def npy_float32_and_float64_give_the_aabb_pairs():
    with Tmp() as t:
        scene = t.gen(700, 1)
        rows = read_aabb(scene)
        expected = brute(rows)
        assert len(expected) > 100
        for descr, version in (("<f4", 1), ("<f8", 1), ("<f4", 2)):
            npy = t.path("s.npy")
            open(npy, "wb").write(npy_bytes(rows, descr, version=version))
            r = pairs([npy, "--out", t.path("p.bin")])
            assert r.returncode == 0, r.stderr
            assert pairs_of(open(t.path("p.bin"), "rb").read()) == expected, descr
            assert ('"precision":"f64"' in r.stdout.decode()) == (descr == "<f8")


@test
def npy_of_another_kind_is_refused_with_its_reason():
    rows = [[0, 0, 0, 1, 1, 1]] * 3
    cases = [
        (npy_bytes(rows, "<i4"), "dtype '<i4' is not supported"),
        (npy_bytes(rows, ">f4"), "little-endian"),
        (npy_bytes(rows, fortran=True), "Fortran order"),
        (npy_bytes([[0, 0, 0, 1, 1]] * 3, shape=(3, 5)), "shape (n, 6)"),
        (npy_bytes([r + (0,) for r in map(tuple, rows)], shape=(18,)), "shape (n, 6)"),
        (npy_bytes(rows)[:-4], "does not hold 3 x 6 values"),
        (b"not a numpy file at all", "not a .npy file"),
    ]
    with Tmp() as t:
        for data, message in cases:
            p = t.path("bad.npy")
            open(p, "wb").write(data)
            r = pairs([p])
            assert r.returncode == 1 and message in r.stderr.decode(), (message, r.stderr)


@test
def dash_reads_the_scene_from_stdin_and_writes_pairs_to_stdout():
    with Tmp() as t:
        scene = t.gen(900, 2)
        r = pairs([scene, "--out", t.path("p.bin")])
        assert r.returncode == 0
        want = open(t.path("p.bin"), "rb").read()
        # .aabb on stdin, pairs on stdout: the JSON line moves to stderr
        r = pairs(["-", "--out", "-"], stdin=open(scene, "rb"))
        assert r.returncode == 0, r.stderr
        assert r.stdout == want
        assert b'"n":900' in r.stderr
        # .npy on stdin (told apart by its magic)
        r = pairs(["-", "--out", "-"], input=npy_bytes(read_aabb(scene), "<f8"))
        assert r.returncode == 0 and r.stdout == want, r.stderr


@test
def against_gives_the_two_set_pairs():
    with Tmp() as t:
        a, b = t.gen(400, 3, "a.aabb"), t.gen(500, 4, "b.aabb")
        expected = brute(read_aabb(a), read_aabb(b))
        assert len(expected) > 50
        r = pairs([a, "--against", b, "--out", t.path("p.bin"), "--check"])
        assert r.returncode == 0, r.stderr
        assert b'"na":400,"nb":500' in r.stdout and b'"check":"ok"' in r.stdout
        assert pairs_of(open(t.path("p.bin"), "rb").read()) == expected
        # b from stdin, as .npy float64: the float32 set is widened
        r = pairs([a, "--against", "-", "--out", "-"], input=npy_bytes(read_aabb(b), "<f8"))
        assert r.returncode == 0 and pairs_of(r.stdout) == expected, r.stderr


@test
def check_refuses_more_than_100000_boxes_without_force():
    with Tmp() as t:
        big = t.gen(100001, 5)
        r = pairs([big, "--check"])
        assert r.returncode == 1 and b"--force" in r.stderr, r.stderr
        small = t.gen(300, 6)
        r = pairs([small, "--check", "--force"])
        assert r.returncode == 0 and b'"check":"ok"' in r.stdout


@test
def accuracy_writes_into_the_current_directory():
    with Tmp() as t:
        r = run(["accuracy", "--sizes", "2000", "--repeat", "1", "--scenes", "uniform"], cwd=t.dir)
        assert r.returncode == 0, r.stderr
        assert os.path.exists(t.path("accuracy.md")) and os.path.exists(t.path("accuracy.csv"))


@test
def simulate_finds_its_installed_renderer():
    scene = os.path.join(ROOT, "examples", "scenes", "falling_balls.json")
    probe = run(["simulate", scene, "--steps", "0", "--quiet"])
    if b"not supported" in probe.stdout + probe.stderr:
        return "SKIP no narrow phase in this build"
    with Tmp() as t:
        # An installed layout: PREFIX/bin/locd and PREFIX/share/locd/render_scene.py
        os.makedirs(t.path("bin"))
        os.makedirs(t.path("share/locd"))
        exe = t.path("bin/locd")
        shutil.copy(LOCD, exe)
        marker = t.path("rendered")
        open(t.path("share/locd/render_scene.py"), "w").write(
            "import sys\nopen(%r, 'w').write(' '.join(sys.argv[1:]))\n" % marker)
        env = dict(os.environ)
        env.pop("LOCD_RENDER_SCRIPT", None)
        libdir = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(LOCD))), "lib")
        env["LD_LIBRARY_PATH"] = libdir + os.pathsep + env.get("LD_LIBRARY_PATH", "")
        gif = t.path("out.gif")
        # the scene from stdin
        r = subprocess.run([exe, "simulate", "-", "--steps", "2", "--gif", gif], stdin=open(scene, "rb"), env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        assert r.returncode == 0, r.stderr
        assert os.path.exists(marker), "the installed renderer did not run: " + r.stderr.decode()
        assert "--gif " + gif in open(marker).read()


@test
def progress_only_when_stderr_is_a_terminal():
    with Tmp() as t:
        scene = t.gen(50000, 7)
        r = pairs([scene, "--repeat", "3"])
        assert r.returncode == 0 and b"\r" not in r.stderr and r.stderr == b"", r.stderr
        master, slave = pty.openpty()
        p = subprocess.Popen([LOCD, "pairs", scene, "--repeat", "3"],
                             stdout=subprocess.PIPE, stderr=slave)
        os.close(slave)
        out = b""
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                break
            if not chunk:
                break
            out += chunk
        p.communicate()
        os.close(master)
        assert p.returncode == 0
        assert b"locd: pairs: run" in out, out


def simulate_json(text):
    """`locd simulate` on a scene given as JSON text (on stdin), two steps, quiet."""
    return run(["simulate", "-", "--steps", "2", "--quiet"], input=text.encode())


def refused(r, *words):
    """A non-zero exit (not a signal: returncode > 0) with every word in the message."""
    assert r.returncode > 0, (r.returncode, r.stderr)
    for w in words:
        assert w.encode() in r.stderr, (w, r.stderr)


@test
def pause_sleeps_before_each_run_outside_the_timed_call():
    """--pause MS: each run follows MS ms of sleep (the wall time grows by about repeat x MS), the
    in-call time does not include it, and a bad value is refused."""
    with Tmp() as t:
        scene = t.gen(2000, 3)
        start = time.monotonic()
        r = pairs([scene, "--repeat", "5", "--pause", "40"])
        wall = time.monotonic() - start
        assert r.returncode == 0, r.stderr
        assert wall >= 5 * 0.040, wall
        assert json.loads(r.stdout)["total_ms"] < 40, r.stdout
        refused(pairs([scene, "--pause", "-1"]), "--pause")
        refused(pairs([scene, "--pause", "1e9"]), "--pause")


@test
def frames_pause_sleeps_before_each_update_and_rebuild_outside_the_timing():
    """locd frames --pause MS: each frame's update and its rebuild follow MS ms of sleep (the wall time
    grows by about 2 x frames x MS), the times reported do not include it, and a bad value is refused."""
    with Tmp() as t:
        scene = t.gen(2000, 3)
        start = time.monotonic()
        r = run(["frames", scene, "--moving", "0.1", "--frames", "4", "--pause", "30"])
        wall = time.monotonic() - start
        assert r.returncode == 0, r.stderr
        assert wall >= 2 * 4 * 0.030, wall
        out = json.loads(r.stdout)
        assert out["update_ms"] < 30 and out["rebuild_ms"] < 30, r.stdout
        refused(run(["frames", scene, "--moving", "0.1", "--frames", "1", "--pause", "-1"]), "--pause")
        refused(run(["frames", scene, "--moving", "0.1", "--frames", "1", "--pause", "1e9"]), "--pause")


@test
def out_of_range_numbers_are_refused_not_crashed_on():
    """Issue 18: --repeat 1e12 segfaulted (unchecked allocation), --seed junk became 0, `gen uniform 1e12`
    said "unknown kind" when the allocation failed."""
    with Tmp() as t:
        scene = t.gen(100, 1)
        refused(pairs([scene, "--repeat", "1e12"]), "--repeat")
        refused(run(["gen", "uniform", "10", "--seed", "junk", "-o", t.path("x.aabb")]), "--seed")
        refused(run(["gen", "uniform", "10", "--seed", "-1", "-o", t.path("x.aabb")]), "--seed")
        refused(run(["frames", scene, "--moving", "0.1", "--frames", "2", "--seed", "7x"]), "--seed")
        refused(run(["gen", "uniform", "1e12", "-o", t.path("x.aabb")]), "out of memory")


@test
def bad_scene_numbers_are_refused_not_crashed_on():
    """Issue 18: a grid layout with a zero count (SIGFPE), "points": -nan (SIGSEGV), steps 1e300."""
    gen = '{"generate": [{"shape": "sphere", "radius": 0.1, "layout": "grid", "grid": %s}]}'
    for grid in ("[0.5, 4, 1]", "[0, 2, 2]", "[-1, -1, 1]"):
        refused(simulate_json(gen % grid), "grid")
    rock = '{"objects": [{"shape": "rock", "radius": 0.5, "points": %s, "position": [0, 0, 0]}]}'
    refused(simulate_json(rock % "-nan"), "bad number")
    refused(simulate_json(rock % "1e999"), "bad number")
    refused(simulate_json('{"steps": 1e300}'), "steps")
    # 42-fuzz: a negative seed was cast to uint64_t (undefined behaviour); a seed is a whole number 0..2^53.
    for seed in ("-6", "0.5", "1e300"):
        refused(simulate_json('{"generate": [{"shape": "sphere", "radius": 0.1, "count": 2, "seed": %s}]}' % seed), "seed")
        refused(simulate_json(rock % ("14, \"seed\": %s" % seed)), "seed")
        refused(simulate_json('{"objects": [{"shape": "terrain", "seed": %s, "position": [0, 0, 0]}]}' % seed), "seed")
    refused(run(["simulate", "-", "--steps", "junk"], input=b"{}"), "--steps")
    refused(run(["simulate", "-", "--threads", "-1"], input=b"{}"), "--threads")
    assert simulate_json(gen % "[2, 2, 1]").returncode == 0
    if os.path.exists("/dev/full"):  # issue 18: a failed --dump write exited 0
        refused(run(["simulate", "-", "--steps", "2", "--quiet", "--dump", "/dev/full"], input=(gen % "[2, 2, 1]").encode()),
                "cannot write")


@test
def generators_of_no_objects_are_empty_not_freed_twice():
    """42-fuzz: a second generator of 0 objects called realloc(p, 0), which freed the object arrays the scene
    still held (a double free when the scene was freed). Zero-object generators are valid and add nothing."""
    empty = '{"shape": "sphere", "radius": 0.1}'
    one = '{"shape": "sphere", "radius": 0.1, "count": 1}'
    for gens in ([empty, empty], [one, empty, empty], [empty, one, empty]):
        r = simulate_json('{"generate": [%s]}' % ", ".join(gens))
        assert r.returncode == 0, (gens, r.returncode, r.stderr.decode())


@test
def a_directory_as_scene_says_so():  # issue 18: "size 9223372036854775807 is not a multiple of 24"
    with Tmp() as t:
        for cmd in (["pairs", t.dir], ["simulate", t.dir], ["frames", t.dir, "--moving", "0.1", "--frames", "1"]):
            r = run(cmd)
            assert r.returncode != 0 and b"is a directory" in r.stderr, (cmd, r.stderr.decode())
            assert b"9223372036854775807" not in r.stderr


@test
def names_and_paths_are_escaped_in_the_json_output():  # issue 18: names were not escaped
    with Tmp() as t:
        out = t.path('a"b\\c\td.aabb')
        r = run(["gen", "uniform", "10", "-o", out])
        assert r.returncode == 0, r.stderr.decode()
        assert json.loads(r.stdout.decode())["out"] == out
        scene = {"name": 'he said "hi"\n\\', "objects": [
            {"shape": "sphere", "radius": 0.5, "position": [0, 0, 1], "name": 'x"y\u0001'}]}
        r = run(["simulate", "-", "--steps", "2", "--quiet"], input=json.dumps(scene).encode())
        assert r.returncode == 0, r.stderr.decode()
        summary = json.loads(r.stdout.decode().strip().splitlines()[-1])["summary"]
        assert summary["scene"] == scene["name"], summary["scene"]
        assert list(summary["tracked"]) == ['x"y\u0001'], summary["tracked"]


class Serve:
    """`locd serve ARGS` in the background, its stderr in a file; .address once it listens."""

    def __init__(self, tmp, args, env=None):
        self.log = tmp.path("serve-%d.log" % id(self))
        self.err = open(self.log, "w")
        self.proc = subprocess.Popen([LOCD, "serve"] + args, stdout=subprocess.DEVNULL, stderr=self.err,
                                     env=env)
        self.address = None
        for _ in range(500):
            text = self.text()
            if "listening on " in text:
                self.address = text.split("listening on ", 1)[1].split()[0]
                break
            if self.proc.poll() is not None:
                break
            __import__("time").sleep(0.01)

    def text(self):
        return open(self.log).read()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
        self.proc.wait(timeout=30)
        self.err.close()


SECRET = "cli-test-secret-0123456789abcdef"


@test
def serve_takes_the_secret_from_a_file_or_the_environment():  # issue 18 item 9
    with Tmp() as t:
        scene = t.gen(300, 5)
        secret = t.path("secret")
        with open(secret, "w") as f:
            f.write(SECRET + "\n")
        os.chmod(secret, 0o600)
        env = dict(os.environ, LOCD_SECRET=SECRET)
        for args, senv in (([ "--secret-file", secret], None), ([], env)):
            svc = Serve(t, ["--listen", "tcp:127.0.0.1:0", "--threads", "1"] + args, env=senv)
            try:
                assert svc.address, "serve did not start: " + svc.text()
                assert "command line" not in svc.text(), svc.text()
                r = pairs([scene, "--service", svc.address, "--secret-file", secret])
                assert r.returncode == 0, r.stderr.decode()
                r = pairs([scene, "--service", svc.address], env=env)
                assert r.returncode == 0, r.stderr.decode()
                r = pairs([scene, "--service", svc.address])
                assert r.returncode != 0 and b"secret" in r.stderr, r.stderr.decode()
            finally:
                svc.stop()


@test
def serve_warns_about_a_command_line_secret_and_hides_it():
    with Tmp() as t:
        svc = Serve(t, ["--listen", "tcp:127.0.0.1:0", "--threads", "1", "--secret", SECRET])
        try:
            assert svc.address, "serve did not start: " + svc.text()
            assert "/proc/PID/cmdline" in svc.text(), svc.text()
            cmdline = open("/proc/%d/cmdline" % svc.proc.pid, "rb").read()
            assert SECRET.encode() not in cmdline, cmdline
            r = pairs([t.gen(200, 3), "--service", svc.address], env=dict(os.environ, LOCD_SECRET=SECRET))
            assert r.returncode == 0, r.stderr.decode()
        finally:
            svc.stop()


@test
def serve_refuses_a_short_secret_and_warns_about_a_wildcard_bind():
    with Tmp() as t:
        r = run(["serve", "--listen", "tcp:127.0.0.1:0"], env=dict(os.environ, LOCD_SECRET="short"))
        assert r.returncode == 2 and b"at least 16" in r.stderr, r.stderr.decode()
        empty = t.path("empty")
        open(empty, "w").close()
        r = run(["serve", "--listen", "tcp:127.0.0.1:0", "--secret-file", empty])
        assert r.returncode == 2 and b"no secret" in r.stderr, r.stderr.decode()
        svc = Serve(t, ["--listen", "tcp:0.0.0.0:0", "--threads", "1"], env=dict(os.environ, LOCD_SECRET=SECRET))
        try:
            assert svc.address, "serve did not start: " + svc.text()
            assert "every network interface" in svc.text(), svc.text()
        finally:
            svc.stop()


def main():
    print("1..%d" % len(RESULTS))
    failed = 0
    for k, fn in enumerate(RESULTS, 1):
        try:
            note = fn()
            print("ok %d - %s%s" % (k, fn.__name__, " # " + note if note else ""))
        except Exception as e:  # a failed assertion or a crash: report and go on
            failed += 1
            print("not ok %d - %s" % (k, fn.__name__))
            for line in ("%s: %s" % (type(e).__name__, e)).splitlines():
                print("# " + line)
        sys.stdout.flush()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
