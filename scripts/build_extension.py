#!/usr/bin/env python3
"""Build the installable Blender extension zip: blender_addon/ plus the release binary at bin/caustic.

Usage: scripts/build_extension.py [BINARY] [--out-dir DIR]
  BINARY   the caustic executable to ship (default: target/release/caustic)
  --out-dir where to write caustic-<version>-<platform>.zip (default: dist/)

The zip is what Blender's "Install from Disk" (or `bpy.ops.extensions.package_install_files`)
takes. Because it carries a native binary, the manifest inside the zip gets a `platforms` entry
for the platform the binary was built on; the add-on source itself stays platform-neutral.
Only the Python standard library is used, so this runs without Blender.
"""

import argparse
import os
import platform
import re
import stat
import sys
import time
import zipfile

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
ADDON = os.path.join(REPO, "blender_addon")
SKIP_DIRS = {"__pycache__", "bin"}
SKIP_SUFFIXES = (".pyc", ".pyo")


def blender_platform():
    """This machine's platform in the extension manifest's vocabulary (e.g. linux-x64)."""
    system = {"linux": "linux", "darwin": "macos", "win32": "windows"}.get(sys.platform)
    machine = platform.machine().lower()
    arch = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(machine)
    if system is None or arch is None:
        raise SystemExit(f"unsupported platform for a binary extension: {sys.platform} {machine}")
    return f"{system}-{arch}"


def manifest_with_platform(text, plat):
    """The manifest text with `platforms = ["<plat>"]` (replacing any existing entry)."""
    line = f'platforms = ["{plat}"]'
    if re.search(r"(?m)^platforms\s*=", text):
        return re.sub(r"(?m)^platforms\s*=.*$", line, text)
    # Top-level keys must come before the first [table].
    first_table = re.search(r"(?m)^\[", text)
    at = first_table.start() if first_table else len(text)
    return text[:at] + line + "\n\n" + text[at:]


def manifest_version(text):
    match = re.search(r'(?m)^version\s*=\s*"([^"]+)"', text)
    if not match:
        raise SystemExit("blender_manifest.toml has no version")
    return match.group(1)


def addon_files():
    """(absolute path, path inside the zip) for every file of the add-on to ship."""
    for root, dirs, files in os.walk(ADDON):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        for name in sorted(files):
            if name.endswith(SKIP_SUFFIXES):
                continue
            path = os.path.join(root, name)
            yield path, os.path.relpath(path, ADDON).replace(os.sep, "/")


def build(binary, out_dir):
    """Write the zip and return its path."""
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        raise SystemExit(f"no executable caustic binary at {binary} (cargo build --release first)")
    plat = blender_platform()
    with open(os.path.join(ADDON, "blender_manifest.toml"), encoding="utf-8") as f:
        manifest = f.read()
    version = manifest_version(manifest)
    os.makedirs(out_dir, exist_ok=True)
    out = os.path.join(out_dir, f"caustic-{version}-{plat}.zip")
    exe_name = "caustic.exe" if plat.startswith("windows") else "caustic"
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for path, arcname in addon_files():
            if arcname == "blender_manifest.toml":
                zf.writestr(arcname, manifest_with_platform(manifest, plat))
            else:
                zf.write(path, arcname)
        info = zipfile.ZipInfo(f"bin/{exe_name}", date_time=time.localtime(os.path.getmtime(binary))[:6])
        info.compress_type = zipfile.ZIP_DEFLATED
        # Record rwxr-xr-x; extractors that honour it keep the binary executable (the add-on
        # restores the bit itself for those that do not).
        info.external_attr = (stat.S_IFREG | 0o755) << 16
        with open(binary, "rb") as f:
            zf.writestr(info, f.read())
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("binary", nargs="?", default=os.path.join(REPO, "target", "release", "caustic"))
    parser.add_argument("--out-dir", default=os.path.join(REPO, "dist"))
    args = parser.parse_args()
    print(build(os.path.abspath(args.binary), os.path.abspath(args.out_dir)))


if __name__ == "__main__":
    main()
