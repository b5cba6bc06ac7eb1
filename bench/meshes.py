#!/usr/bin/env python3
"""bench/meshes.py: triangle meshes as locd scenes (one box per triangle).

    bench/meshes.py --out DIR [--scenes terrain,cad,organic] [--cache DIR]
        fetch the public meshes (Debian's libcgal-demo package), convert them and write
        DIR/mesh-NAME.aabb; prints one line per scene (name, file, triangles, source)
    bench/meshes.py --list
        the scenes this script makes and where they come from
    bench/meshes.py --fetch-only [--cache DIR]
        only download and unpack the meshes into the cache
    bench/meshes.py convert MESH OUT.aabb [--refine K]
        any OFF, STL (ascii or binary) or ascii PLY file to a .aabb scene

A scene holds, for every triangle, its axis-aligned box in locd's `.aabb` format (docs/formats.md:
6 float32 values `minx miny minz maxx maxy maxz` a row, little-endian, no header). Polygons with more
than three vertices are cut into a fan of triangles (v0, vi, vi+1). Each vertex coordinate is rounded
to float32 once (parsed as float64, then to the nearest float32); a triangle's box is the minimum and
maximum of its three vertices' float32 values, which is exact, so triangles that share a vertex have
boxes that touch exactly. `--refine K` splits every triangle into four at its edge midpoints, K times;
a midpoint is computed once per edge in float32 ((a + b) * 0.5), so the refined triangles still share
their vertices exactly.

The meshes come from Debian 12's `libcgal-demo` package (CGAL 5.5.1's demo data,
/usr/share/doc/libcgal-dev/data.tar.gz): `apt-get download libcgal-demo` into the cache
(default bench/results/tmp/meshes/, not committed), the data archive taken out of the package with
`dpkg-deb`, and only the meshes used unpacked from it; each is checked against its SHA-256.
Needs numpy.
"""
import argparse
import hashlib
import os
import subprocess
import sys
import tarfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
try:
    import numpy as np
except ImportError:  # re-run under the project's venv (scripts/setup.sh), which has numpy
    venv_py = ROOT / ".venv" / "bin" / "python"
    if __name__ == "__main__" and venv_py.exists() and Path(sys.prefix).resolve() != (ROOT / ".venv").resolve():
        os.execv(str(venv_py), [str(venv_py), __file__] + sys.argv[1:])
    raise
DEFAULT_CACHE = ROOT / "bench" / "results" / "tmp" / "meshes"
PACKAGE = "libcgal-demo"
DATA_IN_DEB = "./usr/share/doc/libcgal-dev/data.tar.gz"
# Members of data.tar.gz used, with their SHA-256 (libcgal-demo 5.5.1-2, Debian 12).
MESH_SHA256 = {
    "data/meshes/three_peaks.off": "6b985fb7f6f2a6dc15dd311758aa1eeb0725cfb32bcacef8a767b910c9a2d8d4",
    "data/meshes/fandisk_large.off": "afd1fda7ca6b7175945d329c365d18f52da50987b8957b58e6f1fb3c07f5555f",
    "data/meshes/armadillo.off": "6f7f3ca1abc506569466b72f2f59d49493a284e7376d7a7e23c08115ec8cec4e",
}
# Scene name -> (mesh member, refinement steps, what it is).
SCENES = {
    "terrain": ("data/meshes/three_peaks.off", 2,
                "three_peaks.off, a terrain: a height field of 3,671 triangles, each split into 4 at its edge "
                "midpoints, twice"),
    "cad": ("data/meshes/fandisk_large.off", 0, "fandisk_large.off, a CAD part: flat faces meeting at sharp edges"),
    "organic": ("data/meshes/armadillo.off", 0, "armadillo.off, a scanned organic model: the Stanford armadillo"),
    "terrain-small": ("data/meshes/three_peaks.off", 0, "three_peaks.off as it is (the CI's mesh scene)"),
}
BENCH_SCENES = ["terrain", "cad", "organic"]


class MeshError(Exception):
    """A mesh file that cannot be read: the message names the file and line."""


# ------------------------------------------------------------------ readers


def _lines(text):
    """(line number, tokens) of each line that holds anything once '#' comments are cut."""
    for no, line in enumerate(text.splitlines(), 1):
        cut = line.split("#", 1)[0].split()
        if cut:
            yield no, cut


def _floats(tokens, where):
    try:
        return [float(t) for t in tokens]
    except ValueError:
        raise MeshError("%s: not a number in %r" % (where, " ".join(tokens))) from None


def _ints(tokens, where):
    try:
        return [int(t) for t in tokens]
    except ValueError:
        raise MeshError("%s: not an integer in %r" % (where, " ".join(tokens))) from None


def _fan(poly, nv, where):
    """The fan (v0, vi, vi+1) of one polygon's vertex indices."""
    if len(poly) < 3:
        raise MeshError("%s: a face needs at least 3 vertices, this one has %d" % (where, len(poly)))
    for v in poly:
        if v < 0 or v >= nv:
            raise MeshError("%s: vertex index %d out of range (the file has %d vertices)" % (where, v, nv))
    return [(poly[0], poly[i], poly[i + 1]) for i in range(1, len(poly) - 1)]


def read_off(path, text):
    """OFF (also COFF, NOFF, CNOFF, STOFF: extra per-vertex values are ignored): vertices, triangles."""
    it = _lines(text)
    try:
        no, tok = next(it)
    except StopIteration:
        raise MeshError("%s: empty file" % path) from None
    head = tok[0]
    if not head.endswith("OFF") or head[:-3].strip("CNST") != "":
        raise MeshError("%s:%d: not an OFF file (first word %r; 4OFF and nOFF are not supported)" % (path, no, head))
    counts = tok[1:]
    if not counts:
        try:
            no, counts = next(it)
        except StopIteration:
            raise MeshError("%s: the header has no vertex and face counts" % path) from None
    if len(counts) < 2:
        raise MeshError("%s:%d: the header needs the vertex and face counts, got %r" % (path, no, " ".join(counts)))
    nv, nf = _ints(counts[:2], "%s:%d" % (path, no))
    if nv < 0 or nf < 0:
        raise MeshError("%s:%d: negative count" % (path, no))
    verts = np.empty((nv, 3), dtype=np.float64)
    for i in range(nv):
        try:
            no, tok = next(it)
        except StopIteration:
            raise MeshError("%s: the file ends after %d of its %d vertices" % (path, i, nv)) from None
        if len(tok) < 3:
            raise MeshError("%s:%d: a vertex needs 3 coordinates, got %r" % (path, no, " ".join(tok)))
        verts[i] = _floats(tok[:3], "%s:%d" % (path, no))
    tris = []
    for i in range(nf):
        try:
            no, tok = next(it)
        except StopIteration:
            raise MeshError("%s: the file ends after %d of its %d faces" % (path, i, nf)) from None
        where = "%s:%d" % (path, no)
        k = _ints(tok[:1], where)[0]
        if len(tok) < 1 + k:
            raise MeshError("%s: the face says %d vertices but lists %d" % (where, k, len(tok) - 1))
        tris += _fan(_ints(tok[1:1 + k], where), nv, where)
    return verts, tris


def read_stl(path, data):
    """STL, binary (80-byte header, count, 50 bytes a triangle) or ascii (facet / vertex lines)."""
    if len(data) >= 84:
        count = int.from_bytes(data[80:84], "little")
        if len(data) == 84 + 50 * count:
            rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                count=count, offset=84)
            return rec["v"].reshape(-1, 3).astype(np.float64), None
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise MeshError("%s: neither a binary STL (the size is not 84 + 50 x its count) nor an ascii one" % path) \
            from None
    it = _lines(text)
    first = next(it, (0, [""]))
    if first[1][0] != "solid":
        raise MeshError("%s: an ascii STL starts with 'solid'" % path)
    pts, facet = [], 0
    for no, tok in it:
        if tok[0] == "vertex":
            if len(tok) != 4:
                raise MeshError("%s:%d: a vertex needs 3 coordinates" % (path, no))
            pts.append(_floats(tok[1:], "%s:%d" % (path, no)))
            facet += 1
        elif tok[0] == "endloop":
            if facet != 3:
                raise MeshError("%s:%d: a facet needs 3 vertices, this one has %d" % (path, no, facet))
            facet = 0
    if facet:
        raise MeshError("%s: the file ends inside a facet" % path)
    return np.array(pts, dtype=np.float64).reshape(-1, 3), None


_PLY_TYPES = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16",
              "uint16", "int32", "uint32", "float32", "float64"}


def read_ply(path, text):
    """ascii PLY: the vertex element's x, y, z and the face element's vertex_indices (or vertex_index) list."""
    lines = text.splitlines()
    if not lines or lines[0].strip() != "ply":
        raise MeshError("%s:1: a PLY file starts with 'ply'" % path)
    elements, at = [], 1
    while True:
        if at >= len(lines):
            raise MeshError("%s: no end_header" % path)
        tok = lines[at].split()
        at += 1
        where = "%s:%d" % (path, at)
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        if tok[0] == "end_header":
            break
        if tok[0] == "format":
            if len(tok) < 2 or tok[1] != "ascii":
                raise MeshError("%s: only ascii PLY is read (this one is %s)" % (where, " ".join(tok[1:2])))
        elif tok[0] == "element" and len(tok) == 3:
            elements.append((tok[1], _ints(tok[2:], where)[0], []))
        elif tok[0] == "property" and elements:
            if tok[1] == "list" and len(tok) == 5:
                elements[-1][2].append((tok[4], True))
            elif len(tok) == 3 and tok[1] in _PLY_TYPES:
                elements[-1][2].append((tok[2], False))
            else:
                raise MeshError("%s: bad property line" % where)
        else:
            raise MeshError("%s: unexpected header line %r" % (where, lines[at - 1].strip()))
    verts, tris, nv = None, [], None
    body = ((no, ln.split()) for no, ln in enumerate(lines[at:], at + 1) if ln.strip())
    for name, count, props in elements:
        names = [p for p, _ in props]
        if name == "vertex":
            if not all(c in names for c in "xyz") or any(is_list for _, is_list in props):
                raise MeshError("%s: the vertex element needs scalar x, y and z properties" % path)
            cols = [names.index(c) for c in "xyz"]
            verts, nv = np.empty((count, 3), dtype=np.float64), count
        for i in range(count):
            try:
                no, tok = next(body)
            except StopIteration:
                raise MeshError("%s: the file ends after %d of its %d %s rows" % (path, i, count, name)) from None
            where = "%s:%d" % (path, no)
            if name == "vertex":
                if len(tok) < len(props):
                    raise MeshError("%s: a vertex row needs %d values" % (where, len(props)))
                verts[i] = _floats([tok[c] for c in cols], where)
            elif name == "face":
                pos = 0
                for pname, is_list in props:
                    if not is_list:
                        pos += 1
                        continue
                    k = _ints(tok[pos:pos + 1], where)[0]
                    if len(tok) < pos + 1 + k:
                        raise MeshError("%s: the list says %d values but has %d" % (where, k, len(tok) - pos - 1))
                    if pname in ("vertex_indices", "vertex_index"):
                        if nv is None:
                            raise MeshError("%s: faces before vertices" % where)
                        tris += _fan(_ints(tok[pos + 1:pos + 1 + k], where), nv, where)
                    pos += 1 + k
    if verts is None:
        raise MeshError("%s: no vertex element" % path)
    return verts, tris


def read_mesh(path):
    """(vertices as float32 (n, 3), triangles as int64 (m, 3)) of an OFF, STL or ascii PLY file."""
    path = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise MeshError("%s: %s" % (path, e.strerror or e)) from None
    ext = os.path.splitext(path)[1].lower()
    if ext == ".stl":
        verts, tris = read_stl(path, data)
    else:
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise MeshError("%s: not a text file (binary PLY and OFF are not read)" % path) from None
        if ext == ".ply":
            verts, tris = read_ply(path, text)
        elif ext == ".off":
            verts, tris = read_off(path, text)
        else:
            raise MeshError("%s: unknown mesh format (OFF, STL and ascii PLY are read: .off, .stl, .ply)" % path)
    if not np.all(np.isfinite(verts)):
        raise MeshError("%s: a vertex coordinate is not finite" % path)
    with np.errstate(over="ignore"):
        v32 = verts.astype(np.float32)  # each coordinate rounded once, to the nearest float32
    if not np.all(np.isfinite(v32)):
        raise MeshError("%s: a vertex coordinate is beyond float32's range" % path)
    if tris is None:  # STL: three vertices a facet, shared vertices repeated; index the distinct ones
        v32, inv = np.unique(v32, axis=0, return_inverse=True)
        t = inv.reshape(-1, 3).astype(np.int64)
    else:
        t = np.array(tris, dtype=np.int64).reshape(-1, 3)
    if len(t) == 0:
        raise MeshError("%s: no faces" % path)
    return v32, t


# ------------------------------------------------------------------ scenes


def refine(v, t):
    """Each triangle split into 4 at its edge midpoints; one midpoint per edge, (a + b) * 0.5 in float32."""
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    mid = ((v[uniq[:, 0]] + v[uniq[:, 1]]) * np.float32(0.5)).astype(np.float32)
    m = len(t)
    inv = inv.reshape(-1) + len(v)
    m01, m12, m20 = inv[:m], inv[m:2 * m], inv[2 * m:]
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    nt = np.concatenate([np.stack(x, axis=1) for x in ((a, m01, m20), (b, m12, m01), (c, m20, m12),
                                                        (m01, m12, m20))])
    return np.concatenate([v, mid]), nt


def boxes(v, t):
    """(m, 6) float32 rows minx miny minz maxx maxy maxz: each triangle's box from its float32 vertices."""
    p = v[t]  # (m, 3 vertices, 3 axes), float32
    return np.ascontiguousarray(np.concatenate([p.min(axis=1), p.max(axis=1)], axis=1), dtype="<f4")


def convert(mesh, out, steps=0):
    """Writes the .aabb scene of a mesh file; returns the number of boxes."""
    v, t = read_mesh(mesh)
    for _ in range(steps):
        v, t = refine(v, t)
    b = boxes(v, t)
    b.tofile(str(out))
    return len(b)


# ------------------------------------------------------------------ fetch


def _sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def fetch(cache, members):
    """The mesh files (members of CGAL's data.tar.gz) in the cache, downloading the package when needed."""
    cache = Path(cache)
    cache.mkdir(parents=True, exist_ok=True)
    paths = {m: cache / m for m in members}
    if all(p.exists() and _sha256(p) == MESH_SHA256[m] for m, p in paths.items()):
        return paths
    data = cache / "data.tar.gz"
    if not data.exists():
        installed = Path("/usr/share/doc/libcgal-dev/data.tar.gz")  # libcgal-demo installed with its docs
        if installed.exists():
            data = installed
        else:
            debs = sorted(cache.glob(PACKAGE + "_*.deb"))
            if not debs:
                try:
                    r = subprocess.run(["apt-get", "download", PACKAGE], cwd=str(cache), stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, universal_newlines=True)
                    out, rc = r.stdout, r.returncode
                except OSError as e:
                    out, rc = str(e), 127
                debs = sorted(cache.glob(PACKAGE + "_*.deb"))
                if rc != 0 or not debs:
                    raise MeshError(
                        "could not download the meshes: `apt-get download %s` in %s failed (exit %d)%s\n"
                        "On Debian 12 run `apt-get update` first (scripts/setup.sh does), or put %s's .deb "
                        "or its data.tar.gz into %s." % (PACKAGE, cache, rc, ":\n" + out.strip()[-1500:] if out.strip()
                                                         else ".", PACKAGE, cache))
            tmp = cache / "data.tar.gz.part"
            with open(tmp, "wb") as f:
                r = subprocess.run("dpkg-deb --fsys-tarfile %s | tar -xO %s" % (debs[-1], DATA_IN_DEB), shell=True,
                                   stdout=f, stderr=subprocess.PIPE, universal_newlines=True)
            if r.returncode != 0:
                tmp.unlink()
                raise MeshError("could not take %s out of %s: %s" % (DATA_IN_DEB, debs[-1], r.stderr.strip()))
            tmp.rename(data)
            for deb in debs:  # the data archive is all that is needed from the package
                deb.unlink()
    try:
        with tarfile.open(str(data), "r:gz") as tar:
            for m, p in paths.items():
                try:
                    f = tar.extractfile(m)
                except KeyError:
                    raise MeshError("%s has no member %s" % (data, m)) from None
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_bytes(f.read())
    except (tarfile.TarError, EOFError, OSError) as e:
        raise MeshError("cannot read %s (%s): delete it and run again" % (data, e)) from None
    for m, p in paths.items():
        if _sha256(p) != MESH_SHA256[m]:
            raise MeshError("%s from %s is not the expected file (SHA-256 %s, expected %s)" % (
                m, data, _sha256(p), MESH_SHA256[m]))
    return paths


def make_scenes(names, out_dir, cache):
    """Fetches and converts the named scenes: [(name, path, boxes, text)]."""
    bad = [n for n in names if n not in SCENES]
    if bad:
        raise MeshError("unknown scene %s (known: %s)" % (", ".join(bad), ", ".join(SCENES)))
    paths = fetch(cache, sorted({SCENES[n][0] for n in names}))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    made = []
    for n in names:
        member, steps, text = SCENES[n]
        out = out_dir / ("mesh-%s.aabb" % n)
        made.append((n, out, convert(paths[member], out, steps), text))
    return made


def main(argv):
    if argv[:1] == ["convert"]:
        ap = argparse.ArgumentParser(prog="meshes.py convert",
                                     description="Write the .aabb scene (one float32 box per triangle) of a mesh.")
        ap.add_argument("mesh", help="an OFF, STL (ascii or binary) or ascii PLY file")
        ap.add_argument("out", help="the .aabb file to write")
        ap.add_argument("--refine", type=int, default=0, help="split each triangle into 4, this many times")
        a = ap.parse_args(argv[1:])
        if a.refine < 0:
            ap.error("--refine must be >= 0")
        try:
            n = convert(a.mesh, a.out, a.refine)
        except MeshError as e:
            print("meshes.py: error: %s" % e, file=sys.stderr)
            return 1
        print("%s: %d triangles -> %s" % (a.mesh, n, a.out))
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="directory for the mesh-NAME.aabb scenes")
    ap.add_argument("--scenes", default=",".join(BENCH_SCENES), help="comma list (default %(default)s)")
    ap.add_argument("--cache", default=str(DEFAULT_CACHE), help="download cache (default %(default)s)")
    ap.add_argument("--list", action="store_true", help="list the scenes")
    ap.add_argument("--fetch-only", action="store_true", help="only download and unpack the meshes")
    a = ap.parse_args(argv)
    if a.list:
        for n, (member, steps, text) in SCENES.items():
            print("%-14s mesh-%s.aabb: %s" % (n, n, text))
        return 0
    try:
        if a.fetch_only:
            for m, p in fetch(a.cache, sorted(MESH_SHA256)).items():
                print("%s: %s" % (m, p))
            return 0
        if not a.out:
            ap.error("--out DIR is required (or --list, --fetch-only, convert)")
        for n, path, count, text in make_scenes([s for s in a.scenes.split(",") if s], a.out, a.cache):
            print("%s %s %d %s" % (n, path, count, text))
    except MeshError as e:
        print("meshes.py: error: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
