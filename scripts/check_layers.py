#!/usr/bin/env python3
"""Checks the library's architecture (docs/architecture.md) against the code.

1. Layers: a file in lib/F/ includes only the private headers of F and of the
   folders below F (core < octree < engine < levels < scene < service < narrow
   < mpi). lib/mpi/ (liblocd_mpi, a library of its own) sits on the core
   alone: it includes core/ and octree/ only, and reaches liblocd through
   its public functions and the LC_SHARED helpers (the linker refuses any
   other).
2. No circular dependencies between files: in the compiled objects of
   liblocd, file A depends on file B when A uses a symbol (function or data)
   that B defines; the graph must have no cycle. Reading the objects (nm)
   rather than the source sees every call, including those made through
   macros.

Usage: check_layers.py SOURCE_ROOT BUILD_LIB_DIR
Prints each violation and exits 1 if there is any; exits 0 otherwise.
"""
import glob
import os
import re
import subprocess
import sys

LAYERS = ["core", "octree", "engine", "levels", "scene", "service", "narrow", "mpi"]
# Folders that may include only some of the layers below them.
ONLY = {"mpi": {"core", "octree", "mpi"}}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/[a-z_]+\.h"', re.M)


def check_includes(lib):
    bad = []
    for folder in LAYERS:
        rank = LAYERS.index(folder)
        for path in sorted(glob.glob(os.path.join(lib, folder, "*.[ch]")) +
                           glob.glob(os.path.join(lib, folder, "*.cpp"))):
            for target in INCLUDE.findall(open(path, encoding="utf-8").read()):
                if target not in LAYERS:
                    continue  # "locd/locd.h" and friends: the public headers
                if LAYERS.index(target) > rank:
                    bad.append(f"{os.path.relpath(path, lib)} includes {target}/ (a layer above {folder}/)")
                elif folder in ONLY and target not in ONLY[folder]:
                    bad.append(f"{os.path.relpath(path, lib)} includes {target}/ ({folder}/ uses only "
                               f"{', '.join(sorted(ONLY[folder] - {folder}))})")
    return bad


def symbols(obj):
    out = subprocess.run(["nm", "--defined-only", "-g", obj], capture_output=True, text=True, check=True).stdout
    defined = {line.split()[-1] for line in out.splitlines() if line.strip()}
    out = subprocess.run(["nm", "-u", obj], capture_output=True, text=True, check=True).stdout
    used = {line.split()[-1] for line in out.splitlines() if line.strip()}
    return defined, used


def source_name(obj):
    """lib/liblocd.so.0.1.0.p/core_error.c.o -> core/error.c"""
    base = os.path.basename(obj)[: -len(".o")]
    folder, _, rest = base.partition("_")
    return f"{folder}/{rest}" if folder in LAYERS else base


def check_cycles(build_lib):
    objs = [o for o in glob.glob(os.path.join(build_lib, "**", "*.o"), recursive=True)
            if os.sep + "liblocd" in o and "locd-worker" not in o]
    if not objs:
        return [f"no objects of liblocd under {build_lib} (build the library first)"]
    defs, uses = {}, {}
    for o in objs:
        name = source_name(o)
        d, u = symbols(o)
        uses[name] = u
        for s in d:
            defs.setdefault(s, name)
    edges = {n: sorted({defs[s] for s in u if s in defs and defs[s] != n}) for n, u in uses.items()}
    # Tarjan's strongly connected components.
    index, low, stack, on, sccs, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    bad = []
    for comp in sccs:
        ties = []
        for a in comp:
            for b in comp:
                if a != b:
                    names = sorted(s for s in uses[a] if defs.get(s) == b)
                    if names:
                        ties.append(f"    {a} -> {b}: {', '.join(names[:4])}")
        bad.append("circular dependency: " + " <-> ".join(comp) + "\n" + "\n".join(ties))
    return bad


def main():
    if len(sys.argv) != 3:
        print(__doc__.strip().splitlines()[-3])
        return 2
    src, build_lib = sys.argv[1], sys.argv[2]
    bad = check_includes(os.path.join(src, "lib")) + check_cycles(build_lib)
    for b in bad:
        print(b)
    print(f"layers: {len(bad)} violation(s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
