"""bench/meshes.py, the mesh-to-scene converter: hand-made meshes with known boxes, and bad input.

Run by CI step 60-bench-smoke: `python3 -m pytest tests/tools/test_meshes.py` (needs numpy; no download).
"""
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))
import meshes  # noqa: E402

# A triangle, a quad and a pentagon (fans of 1, 2 and 3 triangles), with comments, blank lines and a colour.
OFF = """# a comment before the header
OFF
# counts
7 3 0

0 0 0     # vertex 0
1 0 0
1 1 0
0 1 0
0.1 0.2 2.5
-1 0.5 3   # vertex 5
2 2 -1
3 0 1 2
4 0 1 2 3   1.0 0.0 0.0
5 3 2 4 5 6
"""
V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.1, 0.2, 2.5], [-1, 0.5, 3], [2, 2, -1]],
             dtype=np.float32)
TRIS = [(0, 1, 2), (0, 1, 2), (0, 2, 3), (3, 2, 4), (3, 4, 5), (3, 5, 6)]


def expected(tris):
    return np.array([np.concatenate([V[list(t)].min(axis=0), V[list(t)].max(axis=0)]) for t in tris],
                    dtype=np.float32)


def write(tmp_path, name, content):
    p = tmp_path / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content)
    return p


def scene(path):
    return np.fromfile(str(path), dtype="<f4").reshape(-1, 6)


def test_off_fans_comments_and_exact_boxes(tmp_path):
    out = tmp_path / "m.aabb"
    assert meshes.convert(write(tmp_path, "m.off", OFF), out) == 6
    assert out.stat().st_size == 6 * 24
    got = scene(out)
    assert np.array_equal(got, expected(TRIS))
    # The box's corners are the vertices' float32 values exactly (0.1 is not a float: its nearest float32).
    assert got[3, 1] == np.float32(0.2) and got[4, 3] == np.float32(0.1) and got[4, 5] == 3


def test_counts_on_the_header_line_and_coff(tmp_path):
    text = OFF.replace("OFF\n# counts\n7 3 0\n", "COFF 7 3 0\n")
    assert np.array_equal(meshes.read_mesh(write(tmp_path, "c.off", text))[1], np.array(TRIS))


def test_shared_vertices_touch_exactly(tmp_path):
    # Two triangles sharing only the vertex (0.7, 0.3, 0.1), none of whose coordinates is a float: their
    # boxes meet exactly there (max of one == min of the other, the vertex's float32 value).
    text = "OFF\n5 2 0\n0.1 0.1 0.1\n0.7 0.3 0.1\n0.2 0.3 0.1\n1.3 0.3 0.1\n1.3 0.9 0.1\n3 0 1 2\n3 1 3 4\n"
    v, t = meshes.read_mesh(write(tmp_path, "t.off", text))
    b = meshes.boxes(v, t)
    assert b[0, 3] == b[1, 0] == np.float32(0.7)
    assert b[0, 4] == b[1, 1] == np.float32(0.3)
    assert b[0, 2] == b[0, 5] == b[1, 2] == np.float32(0.1)


def test_refine_shares_midpoints(tmp_path):
    square = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"
    v, t = meshes.read_mesh(write(tmp_path, "s.off", square))
    v1, t1 = meshes.refine(v, t)
    assert (len(v1), len(t1)) == (9, 8)  # a 3 x 3 grid of vertices: the diagonal's midpoint is shared
    v2, t2 = meshes.refine(v1, t1)
    assert (len(v2), len(t2)) == (25, 32)
    assert len(np.unique(v2, axis=0)) == 25  # no vertex made twice
    b = meshes.boxes(v2, t2)
    assert b[:, :3].min() == 0 and b[:, 3:].max() == 1
    assert set(np.unique(b[:, [0, 1, 3, 4]])) == {np.float32(k / 4) for k in range(5)}
    out = tmp_path / "s.aabb"
    assert meshes.convert(tmp_path / "s.off", out, 2) == 32
    assert np.array_equal(scene(out), b)


def test_stl_ascii_binary_and_ply_match_off(tmp_path):
    tris = [(0, 1, 2), (0, 2, 3), (3, 2, 4)]
    want = expected(tris)
    ascii_stl = "solid t\n" + "".join(
        "facet normal 0 0 1\n outer loop\n" + "".join("  vertex %r %r %r\n" % tuple(float(c) for c in V[i])
                                                      for i in t) + " endloop\nendfacet\n" for t in tris) + \
        "endsolid t\n"
    binary = bytearray(b"binary stl".ljust(80, b" ") + struct.pack("<I", len(tris)))
    for t in tris:
        binary += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *V[i]) for i in t) + b"\0\0"
    ply = ("ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 5\nproperty float x\nproperty float y\n"
           "property float z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_indices\n"
           "end_header\n" + "".join("%r %r %r 7\n" % tuple(float(c) for c in V[i]) for i in range(5)) +
           "4 0 1 2 3\n3 3 2 4\n")
    for name, content in (("a.stl", ascii_stl), ("b.stl", bytes(binary)), ("c.ply", ply)):
        v, t = meshes.read_mesh(write(tmp_path, name, content))
        assert np.array_equal(meshes.boxes(v, t), want), name


@pytest.mark.parametrize("name,content,message", [
    ("empty.off", "# nothing\n\n", "empty file"),
    ("hdr.off", "PLY\n3 1 0\n", "not an OFF file"),
    ("4d.off", "4OFF\n3 1 0\n", "not supported"),
    ("counts.off", "OFF\n3\n", "vertex and face counts"),
    ("short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "ends after 2 of its 3 vertices"),
    ("nan.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "nan.off:4: not a number"),
    ("inf.off", "OFF\n3 1 0\n0 0 0\ninf 0 0\n0 1 0\n3 0 1 2\n", "not finite"),
    ("big.off", "OFF\n3 1 0\n0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n", "beyond float32"),
    ("index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "index.off:6: vertex index 3 out of range"),
    ("two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "at least 3 vertices"),
    ("list.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "says 4 vertices but lists 3"),
    ("faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "ends after 1 of its 2 faces"),
    ("none.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "no faces"),
    ("m.obj", "v 0 0 0\n", "unknown mesh format"),
    ("b.ply", "ply\nformat binary_little_endian 1.0\nend_header\n", "only ascii PLY"),
    ("x.stl", "solid x\nfacet\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n", "a facet needs 3 vertices"),
])
def test_bad_input_is_refused_with_its_reason(tmp_path, name, content, message):
    with pytest.raises(meshes.MeshError, match=message):
        meshes.read_mesh(write(tmp_path, name, content))


def test_command_line(tmp_path):
    good = write(tmp_path, "m.off", OFF)
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "meshes.py"), "convert", str(good),
                        str(tmp_path / "m.aabb"), "--refine", "1"], capture_output=True, text=True)
    assert r.returncode == 0 and "24 triangles" in r.stdout, r.stderr
    bad = write(tmp_path, "bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n")
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "meshes.py"), "convert", str(bad),
                        str(tmp_path / "bad.aabb")], capture_output=True, text=True)
    assert r.returncode == 1
    assert "meshes.py: error:" in r.stderr and "bad.off:6: vertex index 9 out of range" in r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "bad.aabb").exists()


def test_scenes_are_pinned():
    for name, (member, steps, text) in meshes.SCENES.items():
        assert member in meshes.MESH_SHA256 and steps >= 0 and text
    assert set(meshes.BENCH_SCENES) <= set(meshes.SCENES)
