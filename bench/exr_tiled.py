"""Read the renderer's EXR files: single-part, tiled (one level), NONE/RLE/ZIPS/ZIP compression.

tests/blender/exr_io.py reads scanline files (Blender's output); the renderer writes tiled files,
which bpy loads as a multilayer image without pixels. This adds the tiled layout on top of
exr_io's header parsing and ZIP predictor, and OpenEXR's RLE (which uses the same byte split
and predictor as ZIP). Scanline files are handed to exr_io.read_exr.
"""

import struct

import numpy as np

import exr_io  # tests/blender/exr_io.py (run.py puts it on sys.path)

_NONE, _RLE, _ZIPS, _ZIP = 0, 1, 2, 3


def _unrle(data, expected):
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        count = struct.unpack_from("b", data, i)[0]
        i += 1
        if count < 0:
            out += data[i:i - count]
            i -= count
        else:
            out += bytes([data[i]]) * (count + 1)
            i += 1
    if len(out) != expected:
        raise ValueError("bad RLE block size")
    raw = np.frombuffer(bytes(out), dtype=np.uint8)
    t = ((np.cumsum(np.concatenate(([raw[0]], raw[1:].astype(np.int64) - 128)))) & 0xFF).astype(np.uint8)
    half = (t.size + 1) // 2
    res = np.empty_like(t)
    res[0::2] = t[:half]
    res[1::2] = t[half:]
    return res.tobytes()


def read_exr(path):
    """{channel name: float32 array (rows top to bottom)} of a single-part scanline or tiled EXR."""
    with open(path, "rb") as f:
        buf = f.read()
    (version,) = struct.unpack_from("<i", buf, 4)
    if not version & 0x200:
        return exr_io.read_exr(path)
    attrs, pos = exr_io._read_attrs(buf, 8)
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    tw, th, mode = struct.unpack("<IIB", attrs["tiles"][1])
    if mode & 0xF != 0:
        raise ValueError("only one-level tiled EXR files are supported")
    compression = attrs["compression"][1][0]
    if compression not in (_NONE, _RLE, _ZIPS, _ZIP):
        raise ValueError(f"EXR compression {compression} is not supported")
    channels = exr_io._channels(attrs["channels"][1])
    sizes = [exr_io._PIXEL_DTYPES[t].itemsize for _, t in channels]
    ntx, nty = (width + tw - 1) // tw, (height + th - 1) // th
    offsets = struct.unpack_from(f"<{ntx * nty}Q", buf, pos)
    result = {name: np.zeros((height, width), np.float32) for name, _ in channels}
    for off in offsets:
        tx, ty, _lx, _ly, size = struct.unpack_from("<iiiii", buf, off)
        data = buf[off + 20:off + 20 + size]
        px, py = tx * tw, ty * th
        w, h = min(tw, width - px), min(th, height - py)
        expected = sum(sizes) * w * h
        if size < expected:
            data = _unrle(data, expected) if compression == _RLE else exr_io._unzip(data, expected)
        p = 0
        for row in range(h):
            for (name, ptype), s in zip(channels, sizes):
                n = s * w
                result[name][py + row, px:px + w] = np.frombuffer(
                    data[p:p + n], dtype=exr_io._PIXEL_DTYPES[ptype]).astype(np.float32)
                p += n
    return result
