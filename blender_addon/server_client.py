"""The client side of `caustic serve` (docs/protocol.md), without Blender.

`ServerClient` starts the binary lazily, sends framed requests, and reads replies on a thread:
the latest frame is kept for drawing, replies to requests are waited for. It remembers the
state it sent (scene, view, settings, rendering), so that a server that died is started again
and brought back to where it was; the viewport reports the crash and Blender carries on.
The bench (bench/viewport.py) and the tests use it as the add-on does.
"""

import json
import queue
import struct
import subprocess
import threading
import time

PROTOCOL_VERSION = 3
REPLY_TIMEOUT_SECONDS = 60.0


class ServerError(Exception):
    """The server refused a request (its reason) or could not be reached."""


def encode(header, payload=b""):
    """One framed message: u32 header length, u32 payload length, JSON header, payload."""
    h = json.dumps(header).encode()
    return struct.pack("<II", len(h), len(payload)) + h + payload


def _read_exact(stream, n):
    data = b""
    while len(data) < n:
        chunk = stream.read(n - len(data))
        if not chunk:
            return None
        data += chunk
    return data


def read_message(stream):
    """The next (header dict, payload bytes), or None at the end of the stream."""
    prefix = _read_exact(stream, 8)
    if prefix is None:
        return None
    hlen, plen = struct.unpack("<II", prefix)
    header = _read_exact(stream, hlen)
    payload = _read_exact(stream, plen) if plen else b""
    if header is None or payload is None:
        return None
    return json.loads(header), payload


def frame_pixels(header, payload):
    """A frame's RGBA as a float32 numpy array of shape (height, width, 4), rows bottom first
    (OpenGL's and Blender's image order; the server sends the top row first)."""
    import numpy as np

    dtype = {"f16": "<f2", "f32": "<f4", "u8": "u1"}.get(header.get("format"))
    if dtype is None:
        raise ServerError(f"frame format {header.get('format')!r} is not f16, f32 or u8")
    w, h = header["width"], header["height"]
    px = np.frombuffer(payload, dtype=dtype)
    if px.size != w * h * 4:
        raise ServerError(f"frame of {w}x{h} carries {px.size} values, not {w * h * 4}")
    px = px.reshape(h, w, 4)[::-1].astype(np.float32)
    if header["format"] == "u8":
        # Back to linear: sRGB-decoded colour, linear alpha (docs/protocol.md).
        px /= 255.0
        c = px[..., :3]
        px[..., :3] = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return px


class ServerClient:
    """One `caustic serve` process and the state it was given."""

    def __init__(self, binary, threads=None, on_frame=None):
        self.binary = binary
        self.threads = threads
        self.on_frame = on_frame
        self.process = None
        self.restarts = 0
        self.latest_frame = None  # (header, payload) of the newest generation
        self.generation = 0
        self.done = None
        self.render_error = None
        self._replies = queue.Queue()
        self._lock = threading.Lock()
        # What to send again after a restart, in order.
        self._state = {}

    # ---- process ----------------------------------------------------------------------

    def alive(self):
        """Whether the server process is running."""
        return self.process is not None and self.process.poll() is None

    def start(self):
        """Start the server and check the protocol version."""
        argv = [self.binary, "serve"]
        if self.threads:
            argv += ["--threads", str(self.threads)]
        self.process = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        # Each process gets its own reply queue: the reader of a killed server puts its end
        # (None) into that server's queue, never into the one its successor answers on.
        self._replies = queue.Queue()
        threading.Thread(target=self._reader, args=(self.process, self._replies), daemon=True).start()
        reply = self.request({"type": "hello", "version": PROTOCOL_VERSION}, replay=False)
        if reply.get("version") != PROTOCOL_VERSION:
            raise ServerError(f"the server speaks protocol {reply.get('version')}, not {PROTOCOL_VERSION}")

    def ensure_running(self):
        """Start the server if it is not running; after a crash, restore the state it had.
        Returns a message saying so when it restarted a server that died, else None."""
        if self.alive():
            return None
        crashed = self.process is not None
        code = self.process.returncode if crashed else None
        self.start()
        for key in ("settings", "load", "camera", "render"):
            if key in self._state:
                header, payload = self._state[key]
                self.request(header, payload, replay=False)
        if crashed:
            self.restarts += 1
            return f"Caustic's viewport server stopped (exit code {code}); restarted it"
        return None

    def stop(self):
        """End the server: quit, then terminate if it does not."""
        p, self.process = self.process, None
        if p is None:
            return
        try:
            if p.poll() is None:
                p.stdin.write(encode({"type": "quit"}))
                p.stdin.flush()
                p.stdin.close()
            p.wait(timeout=5)
        except (OSError, subprocess.TimeoutExpired):
            p.kill()
            p.wait()

    # ---- messages ---------------------------------------------------------------------

    def _reader(self, process, replies):
        while True:
            try:
                msg = read_message(process.stdout)
            except (OSError, ValueError):
                msg = None
            if msg is None:
                replies.put(None)
                return
            header, payload = msg
            kind = header.get("type")
            if kind == "frame":
                with self._lock:
                    if header["generation"] >= self.generation:
                        self.latest_frame = (header, payload)
                if self.on_frame:
                    self.on_frame(header)
            elif kind == "done":
                with self._lock:
                    if header["generation"] >= self.generation:
                        self.done = header
            elif kind == "error" and "generation" in header:
                # The render failed (not a reply): the viewport reports it on its next draw.
                with self._lock:
                    self.render_error = header.get("message")
            elif kind in ("ok", "error", "hello"):
                replies.put(header)

    def request(self, header, payload=b"", replay=True):
        """Send one request and wait for its reply; raise ServerError on an error reply.
        With `replay`, the request is remembered for a restart (the last of each kind)."""
        if replay:
            self.ensure_running()
        try:
            self.process.stdin.write(encode(header, payload))
            self.process.stdin.flush()
        except OSError as err:
            raise ServerError(f"the viewport server is not reachable: {err}") from err
        try:
            reply = self._replies.get(timeout=REPLY_TIMEOUT_SECONDS)
        except queue.Empty as err:
            raise ServerError(f"no reply to '{header.get('type')}' in {REPLY_TIMEOUT_SECONDS} s") from err
        if reply is None:
            raise ServerError(f"the viewport server ended while handling '{header.get('type')}'")
        if reply.get("type") == "error":
            raise ServerError(reply.get("message", "unknown error"))
        if "generation" in reply:
            with self._lock:
                self.generation = reply["generation"]
                # The reader may have stored the new generation's `done` before this thread
                # woke up with the reply (a small frame renders in a millisecond): keep it.
                if self.done is not None and self.done["generation"] < self.generation:
                    self.done = None
        if replay:
            self._remember(header, payload)
        return reply

    def _remember(self, header, payload):
        kind = header["type"]
        if kind == "render_start":
            self._state["render"] = (header, payload)
        elif kind == "render_stop":
            self._state.pop("render", None)
        elif kind == "settings":
            merged = dict(self._state.get("settings", ({"type": "settings"}, b""))[0])
            merged.update(header)
            self._state["settings"] = (merged, b"")
        elif kind in ("load", "camera"):
            self._state[kind] = (header, payload)
        # Scene edits are folded into the next load (the add-on re-exports on a restart).

    def take_state(self):
        """(latest frame, done message, render error) as one consistent snapshot; the error is
        cleared (it is reported once)."""
        with self._lock:
            state = (self.latest_frame, self.done, self.render_error)
            self.render_error = None
        return state

    def wait_frame(self, generation, timeout=30.0, final=False):
        """The first frame of `generation` or later (the converged one with `final`)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self._lock:
                frame, done = self.latest_frame, self.done
            if frame and frame[0]["generation"] >= generation:
                if not final or (done and done["generation"] >= generation and frame[0]["samples"] >= done["samples"]):
                    return frame
            if not self.alive():
                raise ServerError("the viewport server ended")
            time.sleep(0.002)
        raise ServerError(f"no frame of generation {generation} within {timeout} s")
