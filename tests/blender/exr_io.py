"""Minimal single-part scanline OpenEXR reader/writer for the tests (no OpenEXR binding needed).

The writer makes uncompressed float files with any channel names, so the add-on's result
loading can be tested without the renderer. The reader handles NONE, ZIPS and ZIP
compression of half/float channels, enough to inspect the renderer's own output.
"""

import struct
import zlib

import numpy as np

_MAGIC = 20000630
_PIXEL_DTYPES = {1: np.dtype("<f2"), 2: np.dtype("<f4"), 0: np.dtype("<u4")}
_LINES_PER_BLOCK = {0: 1, 2: 1, 3: 16}


def _attr(name, type_name, payload):
    return name.encode() + b"\0" + type_name.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def write_exr(path, channels):
    """Write {name: 2-D float array (rows top to bottom)} as an uncompressed float EXR."""
    names = sorted(channels)  # EXR stores channels sorted by name
    height, width = np.asarray(channels[names[0]]).shape
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for n in names) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join([
        struct.pack("<ii", _MAGIC, 2),
        _attr("channels", "chlist", chlist),
        _attr("compression", "compression", b"\0"),
        _attr("dataWindow", "box2i", box),
        _attr("displayWindow", "box2i", box),
        _attr("lineOrder", "lineOrder", b"\0"),
        _attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        _attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        _attr("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        b"\0",
    ])
    line_bytes = 4 * width * len(names)
    block = 8 + line_bytes
    first = len(header) + 8 * height
    offsets = struct.pack(f"<{height}Q", *(first + y * block for y in range(height)))
    data = [np.asarray(channels[n], dtype="<f4") for n in names]
    with open(path, "wb") as f:
        f.write(header + offsets)
        for y in range(height):
            f.write(struct.pack("<ii", y, line_bytes))
            for d in data:
                f.write(d[y].tobytes())


def _read_attrs(buf, pos):
    attrs = {}
    while buf[pos] != 0:
        end = buf.index(b"\0", pos)
        name = buf[pos:end].decode()
        tend = buf.index(b"\0", end + 1)
        type_name = buf[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", buf, tend + 1)
        attrs[name] = (type_name, buf[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return attrs, pos + 1


def _read_headers(buf):
    magic, version = struct.unpack_from("<ii", buf, 0)
    if magic != _MAGIC:
        raise ValueError("not an OpenEXR file")
    if version & 0x200:
        raise ValueError("tiled EXR is not supported")
    multipart = bool(version & 0x1000)
    headers, pos = [], 8
    while True:
        attrs, pos = _read_attrs(buf, pos)
        headers.append(attrs)
        if not multipart or buf[pos] == 0:
            break
    return headers, pos + 1 if multipart else pos, multipart


def _channels(payload):
    out, pos = [], 0
    while payload[pos] != 0:
        end = payload.index(b"\0", pos)
        ptype, _plin, xs, ys = struct.unpack_from("<iB3xii", payload, end + 1)
        if (xs, ys) != (1, 1):
            raise ValueError("subsampled channels are not supported")
        out.append((payload[pos:end].decode(), ptype))
        pos = end + 17
    return out


def _unzip(data, expected):
    raw = np.frombuffer(zlib.decompress(data), dtype=np.uint8)
    if raw.size != expected:
        raise ValueError("bad ZIP block size")
    # Undo the byte-delta predictor, then the even/odd byte split.
    t = ((np.cumsum(np.concatenate(([raw[0]], raw[1:].astype(np.int64) - 128)))) & 0xFF).astype(np.uint8)
    half = (t.size + 1) // 2
    out = np.empty_like(t)
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def read_exr(path):
    """Read a scanline EXR into {channel name: float32 array (rows top to bottom)}.

    Multi-part files (as Blender writes multilayer EXR) are merged into one dictionary.
    """
    with open(path, "rb") as f:
        buf = f.read()
    headers, pos, multipart = _read_headers(buf)
    parts = []
    for attrs in headers:
        x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
        compression = attrs["compression"][1][0]
        if compression not in _LINES_PER_BLOCK:
            raise ValueError(f"EXR compression {compression} is not supported by this test reader")
        height = y1 - y0 + 1
        lines = _LINES_PER_BLOCK[compression]
        nblocks = (height + lines - 1) // lines
        offsets = struct.unpack_from(f"<{nblocks}Q", buf, pos)
        pos += 8 * nblocks
        parts.append((attrs, x1 - x0 + 1, height, y0, lines, compression, offsets))
    result = {}
    for attrs, width, height, y0, lines, compression, offsets in parts:
        channels = _channels(attrs["channels"][1])
        chans = {name: np.zeros((height, width), np.float32) for name, _ in channels}
        for off in offsets:
            if multipart:
                off += 4  # part number
            y, size = struct.unpack_from("<ii", buf, off)
            data = buf[off + 8:off + 8 + size]
            row0 = y - y0
            nrows = min(lines, height - row0)
            expected = sum(_PIXEL_DTYPES[t].itemsize for _, t in channels) * width * nrows
            if compression != 0 and size < expected:
                data = _unzip(data, expected)
            p = 0
            for r in range(nrows):
                for name, ptype in channels:
                    dt = _PIXEL_DTYPES[ptype]
                    n = dt.itemsize * width
                    chans[name][row0 + r] = np.frombuffer(data[p:p + n], dtype=dt).astype(np.float32)
                    p += n
        result.update(chans)
    return result
