#!/usr/bin/env python3
"""The Unity package's .meta files and its consistency checks (bindings/unity).

Unity identifies every asset by the GUID in its .meta file; a package added
from a Git URL is immutable, so its .meta files must be committed, and the
GUIDs must never change (scenes and prefabs of users refer to them). Here a
GUID is md5("com.locd.collision/" + the asset's path inside the package):
the same path always gets the same GUID, on any machine, with no state.

  unity_package.py meta      writes the missing .meta files, rewrites wrong
                             ones, deletes orphans (run after adding a file)
  unity_package.py check     exit 1 unless every asset has its .meta with the
                             expected GUID and importer, no .meta is orphaned,
                             GUIDs are unique, LICENSE.md equals the
                             repository's LICENSE byte for byte, and
                             package.json and CHANGELOG.md agree
  unity_package.py plugin FILE
                             writes FILE.meta for a native plugin built into
                             Plugins/<OS>/<CPU>/ (build-plugin.sh), with the
                             import settings of that platform

Assets: the package's files known to git (or, outside git, on disk) and
their folders, except hidden names (.gitignore, .gitkeep: Unity skips them),
the Samples~ folder itself (Unity does not import it; its contents do get
.meta files so an imported sample keeps stable GUIDs) and native plugin
binaries (not committed; `plugin` gives them their .meta when built).
"""
import hashlib
import json
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PKG = os.path.join(ROOT, "bindings", "unity")
PACKAGE_NAME = "com.locd.collision"
PLUGIN_EXT = (".so", ".dll", ".dylib", ".bundle", ".a")

TAIL = "  userData: \n  assetBundleName: \n  assetBundleVariant: \n"


def guid(rel):
    return hashlib.md5((PACKAGE_NAME + "/" + rel).encode("utf-8")).hexdigest()


def importer_body(rel, is_dir):
    if is_dir:
        return "folderAsset: yes\nDefaultImporter:\n  externalObjects: {}\n" + TAIL
    name = os.path.basename(rel)
    ext = os.path.splitext(name)[1].lower()
    if name == "package.json":
        return "PackageManifestImporter:\n  externalObjects: {}\n" + TAIL
    if ext == ".cs":
        return ("MonoImporter:\n  externalObjects: {}\n  serializedVersion: 2\n  defaultReferences: []\n"
                "  executionOrder: 0\n  icon: {instanceID: 0}\n" + TAIL)
    if ext == ".asmdef":
        return "AssemblyDefinitionImporter:\n  externalObjects: {}\n" + TAIL
    if ext in (".md", ".txt", ".json", ".xml", ".bytes", ".csv"):
        return "TextScriptImporter:\n  externalObjects: {}\n" + TAIL
    return "DefaultImporter:\n  externalObjects: {}\n" + TAIL


def meta_text(rel, is_dir):
    return "fileFormatVersion: 2\nguid: %s\n%s" % (guid(rel), importer_body(rel, is_dir))


def hidden(rel):
    return any(part.startswith(".") for part in rel.split("/"))


def package_files():
    try:
        # Committed files and new ones not yet added (never ignored ones).
        git = ["git", "-C", ROOT, "ls-files", "--cached", "--others", "--exclude-standard", "--", "bindings/unity"]
        out = subprocess.run(git, check=True, capture_output=True, text=True).stdout.split("\n")
        files = [os.path.relpath(os.path.join(ROOT, f), PKG) for f in out if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, _, names in os.walk(PKG):
            files += [os.path.relpath(os.path.join(d, n), PKG) for n in names]
    return sorted(f.replace(os.sep, "/") for f in files)


def assets():
    """{relative path: is_dir} of every asset that needs a .meta."""
    out = {}
    for f in package_files():
        if f.endswith(".meta") or f.endswith(PLUGIN_EXT):
            continue
        parts = f.split("/")
        for i in range(1, len(parts)):  # the folders above it (a .gitkeep keeps a folder)
            folder = "/".join(parts[:i])
            if not hidden(folder) and folder != "Samples~":
                out[folder] = True
        if not hidden(f):
            out[f] = False
    return out


def write_if_changed(path, text):
    try:
        with open(path, newline="") as fh:
            if fh.read() == text:
                return False
    except FileNotFoundError:
        pass
    with open(path, "w", newline="\n") as fh:
        fh.write(text)
    return True


def committed_metas():
    return [f for f in package_files() if f.endswith(".meta")]


def cmd_meta():
    want = assets()
    changed = 0
    for rel, is_dir in sorted(want.items()):
        if write_if_changed(os.path.join(PKG, rel + ".meta"), meta_text(rel, is_dir)):
            print("wrote %s.meta" % rel)
            changed += 1
    for m in committed_metas():
        if m[:-5] not in want and not m[:-5].endswith(PLUGIN_EXT):
            os.remove(os.path.join(PKG, m))
            print("removed orphan %s" % m)
            changed += 1
    print("%d assets, %d .meta files changed" % (len(want), changed))
    return 0


def cmd_check():
    problems = []
    want = assets()
    guids = {}
    for rel, is_dir in sorted(want.items()):
        path = os.path.join(PKG, rel + ".meta")
        if not os.path.exists(path):
            problems.append("missing %s.meta" % rel)
            continue
        text = open(path, newline="").read()
        if text != meta_text(rel, is_dir):
            problems.append("%s.meta differs from what `scripts/unity_package.py meta` writes" % rel)
        m = re.search(r"^guid: ([0-9a-f]{32})$", text, re.M)
        if not m:
            problems.append("%s.meta has no guid" % rel)
            continue
        if m.group(1) in guids:
            problems.append("GUID %s of %s is also %s's" % (m.group(1), rel, guids[m.group(1)]))
        guids[m.group(1)] = rel
    for m in committed_metas():
        if m[:-5] not in want:
            problems.append("orphan %s (no such asset)" % m)
    # LICENSE.md in the package is the repository's LICENSE, byte for byte.
    lic, pkg_lic = os.path.join(ROOT, "LICENSE"), os.path.join(PKG, "LICENSE.md")
    if not (os.path.exists(lic) and os.path.exists(pkg_lic)):
        problems.append("LICENSE or bindings/unity/LICENSE.md missing")
    elif open(lic, "rb").read() != open(pkg_lic, "rb").read():
        problems.append("bindings/unity/LICENSE.md is not a copy of LICENSE (cp LICENSE bindings/unity/LICENSE.md)")
    manifest = json.load(open(os.path.join(PKG, "package.json")))
    for key in ("name", "version", "displayName", "description", "unity", "license",
                "documentationUrl", "changelogUrl", "licensesUrl"):
        if not manifest.get(key):
            problems.append("package.json has no %s" % key)
    # The URLs name a file of this repository at the release tag of the
    # package's version (https://github.com/locd/locd/blob/vX.Y.Z/PATH):
    # stable once published, and checked here to name files that exist.
    for key in ("documentationUrl", "changelogUrl", "licensesUrl"):
        m = re.match(r"^https://github\.com/locd/locd/blob/v([^/]+)/(.+)$", manifest.get(key, ""))
        if not m:
            problems.append("package.json %s is not https://github.com/locd/locd/blob/vVERSION/PATH" % key)
        elif m.group(1) != manifest.get("version"):
            problems.append("package.json %s names tag v%s, the package is %s"
                            % (key, m.group(1), manifest.get("version")))
        elif not os.path.exists(os.path.join(ROOT, m.group(2))):
            problems.append("package.json %s names %s, which is not in the repository" % (key, m.group(2)))
    changelog = open(os.path.join(PKG, "CHANGELOG.md")).read()
    if not re.search(r"^## \[%s\]" % re.escape(manifest.get("version", "?")), changelog, re.M):
        problems.append("CHANGELOG.md has no `## [%s]` section (package.json's version)" % manifest.get("version"))
    for p in problems:
        print("FAIL: " + p)
    print("%d assets, %d unique GUIDs, %d problems" % (len(want), len(guids), len(problems)))
    return 1 if problems else 0


def plugin_meta(rel):
    """PluginImporter settings: the plugin loads in the Editor and the
    Standalone player of its OS and CPU only (Plugins/<OS>/<CPU>/file)."""
    parts = rel.split("/")
    os_name, cpu = parts[1], parts[2]
    editor_os = {"Linux": "Linux", "Windows": "Windows", "macOS": "OSX"}[os_name]
    standalone = {"Linux": "Linux64", "Windows": "Win64", "macOS": "OSXUniversal"}[os_name]
    unity_cpu = "x86_64" if cpu == "x86_64" else "ARM64"
    lines = ["fileFormatVersion: 2", "guid: %s" % guid(rel), "PluginImporter:", "  externalObjects: {}",
             "  serializedVersion: 2", "  iconMap: {}", "  executionOrder: {}", "  defineConstraints: []",
             "  isPreloaded: 0", "  isOverridable: 0", "  isExplicitlyReferenced: 0", "  validateReferences: 1",
             "  platformData:", "  - first:", "      : Any", "    second:", "      enabled: 0", "      settings:",
             "        Exclude Editor: 0"]
    for sa in ("Linux64", "OSXUniversal", "Win", "Win64"):
        lines.append("        Exclude %s: %d" % (sa, 0 if sa == standalone else 1))
    lines += ["  - first:", "      Any: ", "    second:", "      enabled: 0", "      settings: {}",
              "  - first:", "      Editor: Editor", "    second:", "      enabled: 1", "      settings:",
              "        CPU: %s" % unity_cpu, "        DefaultValueInitialized: true", "        OS: %s" % editor_os]
    for sa in ("Linux64", "OSXUniversal", "Win", "Win64"):
        lines += ["  - first:", "      Standalone: %s" % sa, "    second:",
                  "      enabled: %d" % (1 if sa == standalone else 0), "      settings:",
                  "        CPU: %s" % (unity_cpu if sa == standalone else "None")]
    return "\n".join(lines) + "\n" + TAIL


def cmd_plugin(path):
    rel = os.path.relpath(os.path.abspath(path), PKG).replace(os.sep, "/")
    if not re.match(r"^Plugins/(Linux|Windows|macOS)/(x86_64|arm64)/[^/]+$", rel):
        sys.exit("not a plugin path Plugins/<Linux|Windows|macOS>/<x86_64|arm64>/FILE: %s" % rel)
    write_if_changed(os.path.join(PKG, rel + ".meta"), plugin_meta(rel))
    print("wrote %s.meta" % rel)
    return 0


def main(argv):
    if argv[1:] == ["meta"]:
        return cmd_meta()
    if argv[1:] == ["check"]:
        return cmd_check()
    if len(argv) == 3 and argv[1] == "plugin":
        return cmd_plugin(argv[2])
    sys.stderr.write(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
