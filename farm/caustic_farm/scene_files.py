"""What a scene needs on a worker: the scene file and every file it refers to, by content.

A glTF names its buffers and images by relative URIs, and Caustic's extensions name more
files (`CAUSTIC_world.image`, the node graphs' `images[].uri`, an IES Texture node's
`ies_file`, `CAUSTIC_volume`'s grid files, `volumes[].uri`). These files travel to the workers keyed by their SHA-256, so a file shared by many frames (one `.bin` under 100
animated `.gltf` files) travels once, and a worker rebuilds each scene's folder from the
content it already holds.
"""

import hashlib
import json
import os
import struct
from urllib.parse import unquote


class SceneError(Exception):
    """The scene cannot be read or names a file that is missing (exit 3 or 4)."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


def read_gltf_json(path):
    """The JSON document of a .gltf or .glb file."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as err:
        raise SceneError(4, f"{path}: cannot read the scene: {err.strerror}") from None
    try:
        if data[:4] == b"glTF":
            length, kind = struct.unpack_from("<II", data, 12)
            if kind != 0x4E4F534A:  # "JSON"
                raise ValueError("the first GLB chunk is not JSON")
            data = data[20:20 + length]
        return json.loads(data)
    except (ValueError, struct.error) as err:
        raise SceneError(3, f"{path}: not a glTF file: {err}") from None


def _uris(node, out):
    """Collects every `uri` and `ies_file` string (and `CAUSTIC_world`'s `image`) found anywhere
    in the JSON."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("uri", "ies_file") and isinstance(value, str):
                out.append(value)
            elif key == "CAUSTIC_world" and isinstance(value, dict) and isinstance(value.get("image"), str):
                out.append(value["image"])
            else:
                _uris(value, out)
    elif isinstance(node, list):
        for value in node:
            _uris(value, out)


def scene_files(path):
    """The scene file and the files it refers to: a list of (relative path, absolute path).

    Data URIs travel inside the scene file. A referenced file that does not exist is left to
    the renderer, which reports it as a bad scene (exit 3) with its own message."""
    path = os.path.abspath(path)
    base = os.path.dirname(path)
    files = [(os.path.basename(path), path)]
    uris = []
    _uris(read_gltf_json(path), uris)
    for uri in uris:
        if uri.startswith("data:") or "://" in uri:
            continue
        rel = os.path.normpath(unquote(uri))
        if os.path.isabs(rel) or rel.startswith(".."):
            raise SceneError(3, f"{path}: refers to {uri} outside its folder, which cannot travel to workers")
        full = os.path.join(base, rel)
        if os.path.isfile(full) and (rel, full) not in files:
            files.append((rel, full))
    return files


def sha256_file(path):
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def scene_setting(path, key):
    """A render setting stored in the scene (`scenes[i].extras.caustic[key]`), or None."""
    doc = read_gltf_json(path)
    scenes = doc.get("scenes") or [{}]
    index = doc.get("scene", 0)
    scene = scenes[index] if isinstance(index, int) and 0 <= index < len(scenes) else {}
    return ((scene.get("extras") or {}).get("caustic") or {}).get(key)


def scene_spp(path, key="spp"):
    """The samples per pixel (or, key `sppm_iterations`, SPPM iterations) the scene asks for, or None."""
    spp = scene_setting(path, key)
    return spp if isinstance(spp, int) else None
