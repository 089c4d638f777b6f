"""Finding and running the `caustic` binary: command line, JSON progress lines, cancellation.

Nothing here touches Blender's render result; the caller gets each progress message through a
callback, on its own thread, and decides what to show.
"""

import json
import os
import queue
import shutil
import subprocess
import sys
import threading
import time

import bpy

from .errors import CausticError

BINARY_ENV = "CAUSTIC_BINARY"
_EXE = "caustic.exe" if sys.platform == "win32" else "caustic"

# Exit codes of the binary (docs/contract.md).
EXIT_OK = 0
EXIT_INTERRUPTED = 5
EXIT_INTERRUPTED_EMPTY = 6
_EXIT_MEANING = {
    1: "internal error in the renderer (please report it)",
    2: "invalid command line or settings",
    3: "invalid or unsupported scene",
    4: "I/O error",
    6: "interrupted before any sample was rendered",
    7: "the scene or settings need more memory than the renderer's memory limit",
}

POLL_SECONDS = 0.1
# After SIGTERM the binary writes the partial image; give it this long before killing it.
TERMINATE_GRACE_SECONDS = 15.0


def _bundled_binary():
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", _EXE)


def _preference_path():
    addon = bpy.context.preferences.addons.get(__package__)
    prefs = getattr(addon, "preferences", None) if addon else None
    path = getattr(prefs, "binary_path", "") if prefs else ""
    return bpy.path.abspath(path) if path else ""


def _ensure_executable(path):
    # Zip extraction drops the executable bit of the shipped binary.
    if not os.access(path, os.X_OK):
        try:
            os.chmod(path, os.stat(path).st_mode | 0o111)
        except OSError:
            pass
    return os.access(path, os.X_OK)


def find_binary():
    """Return the path of the caustic binary to run, or raise CausticError saying where we looked.

    Order: the `CAUSTIC_BINARY` environment variable (a per-process override for scripts, tests
    and render farms, so it wins over the stored preference), then the add-on preference, then
    `bin/caustic` shipped inside the extension, then `caustic` on PATH. A path that is set
    explicitly (environment or preference) but unusable is an error, not a reason to fall back
    silently to another binary.
    """
    for origin, path in ((f"${BINARY_ENV}", os.environ.get(BINARY_ENV, "")),
                         ("the add-on preference", _preference_path())):
        if path:
            if os.path.isfile(path) and _ensure_executable(path):
                return path
            raise CausticError(f"Caustic binary not found or not executable: {path} (set by {origin})")
    bundled = _bundled_binary()
    if os.path.isfile(bundled) and _ensure_executable(bundled):
        return bundled
    on_path = shutil.which("caustic")
    if on_path:
        return on_path
    raise CausticError("Caustic binary not found: set its path in Preferences > Add-ons > Caustic, "
                       f"install the extension with the bundled binary, or put '{_EXE}' on PATH")


OIDN_ENV = "CAUSTIC_OIDN"
_OIDN_NAMES = {"linux": "libOpenImageDenoise.so.2", "darwin": "libOpenImageDenoise.2.dylib",
               "win32": "OpenImageDenoise.dll"}


def find_oidn():
    """The Open Image Denoise library Blender ships, for `--denoise`, or None.

    `$CAUSTIC_OIDN` is left to the binary, which reads it itself; otherwise `lib/` in the
    folders above the bpy module (the bpy wheel) and `lib/` beside Blender's executable. None
    lets the binary search the system and, failing that, refuse with a message naming them.
    """
    if os.environ.get(OIDN_ENV):
        return None
    name = _OIDN_NAMES.get(sys.platform, _OIDN_NAMES["linux"])
    # The bpy wheel keeps the module at bpy/5.0/scripts/modules/bpy/ and the libraries in
    # bpy/lib/: look in lib/ of each folder above the module (a handful of levels).
    folders = []
    here = os.path.dirname(os.path.abspath(bpy.__file__))
    for _ in range(6):
        folders.append(os.path.join(here, "lib"))
        here = os.path.dirname(here)
    if bpy.app.binary_path:
        folders.append(os.path.join(os.path.dirname(bpy.app.binary_path), "lib"))
    for folder in folders:
        candidate = os.path.join(folder, name)
        if os.path.isfile(candidate):
            return candidate
    return None


class RunResult:
    """How a run ended: exit code, the summary and error objects, and any stray output."""

    def __init__(self, code, summary, error, log, cancelled):
        self.code = code
        self.summary = summary
        self.error = error
        self.log = log
        self.cancelled = cancelled

    @property
    def has_image(self):
        """True when the binary wrote its (complete or partial) output image."""
        return self.code in (EXIT_OK, EXIT_INTERRUPTED)

    def error_message(self):
        """A one-line message for a failed run (None when the run succeeded or was interrupted)."""
        if self.code in (EXIT_OK, EXIT_INTERRUPTED):
            return None
        if self.cancelled and (self.code == EXIT_INTERRUPTED_EMPTY or (self.code is not None and self.code < 0)):
            return None  # the user cancelled; a renderer that had to be killed has nothing to show either
        if self.error and self.error.get("message"):
            return f"Caustic: {self.error['message']}"
        meaning = _EXIT_MEANING.get(self.code, "the renderer stopped unexpectedly")
        if self.code is not None and self.code < 0:
            meaning = f"the renderer was killed by signal {-self.code}"
        tail = " | ".join(_printable(line) for line in self.log[-3:] if _printable(line))
        return f"Caustic: {meaning} (exit code {self.code})" + (f": {tail}" if tail else "")


def _printable(line, limit=200):
    """A stray output line fit for a one-line report: control characters dropped, shortened."""
    text = "".join(c for c in line if c.isprintable()).strip()
    return text if len(text) <= limit else text[:limit] + "…"


def _drain(stream, lines):
    """Read the child's stderr line by line until EOF; runs on its own thread."""
    try:
        for raw in iter(stream.readline, b""):
            lines.put(raw.decode("utf-8", errors="replace").rstrip("\r\n"))
    finally:
        lines.put(None)


def run(argv, on_message, should_stop, log_path=None, json_on_stdout=False):
    """Run the binary to the end, calling `on_message(dict)` for every JSON progress line.

    `should_stop()` is polled about every POLL_SECONDS; when it turns true the binary gets
    SIGTERM (it then writes the image rendered so far) and is killed if it does not exit within
    TERMINATE_GRACE_SECONDS. stdout, which the contract keeps empty, goes to `log_path`.
    `json_on_stdout`: the progress lines come on stdout and stderr is the log (the farm
    command's convention: Dask logs to stderr).
    """
    log = open(log_path, "wb") if log_path else subprocess.DEVNULL
    try:
        try:
            if json_on_stdout:
                process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log)
            else:
                process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.PIPE)
        except OSError as err:
            raise CausticError(f"could not start {argv[0]}: {err.strerror}") from None
        return _supervise(process, process.stdout if json_on_stdout else process.stderr, on_message, should_stop)
    finally:
        if log_path:
            log.close()


def _supervise(process, stream, on_message, should_stop):
    lines = queue.Queue()
    reader = threading.Thread(target=_drain, args=(stream, lines), daemon=True)
    reader.start()
    summary = error = None
    log = []
    cancelled_at = None
    eof = False
    try:
        while not eof:
            try:
                line = lines.get(timeout=POLL_SECONDS)
            except queue.Empty:
                line = ""
            if line is None:
                eof = True
            elif line:
                message = _parse(line)
                if message is None:
                    log.append(line)
                else:
                    if message.get("type") == "summary":
                        summary = message
                    elif message.get("type") == "error":
                        error = message
                    on_message(message)
            if cancelled_at is None and should_stop():
                cancelled_at = time.monotonic()
                process.terminate()
            elif cancelled_at is not None and time.monotonic() - cancelled_at > TERMINATE_GRACE_SECONDS:
                process.kill()
        code = process.wait()
    except BaseException:
        # Never leave a renderer running behind Blender's back.
        if process.poll() is None:
            process.kill()
            process.wait()
        raise
    finally:
        reader.join(timeout=1.0)
        stream.close()
    return RunResult(code, summary, error, log, cancelled_at is not None)


def _parse(line):
    if not line.startswith("{"):
        return None
    try:
        message = json.loads(line)
    except ValueError:
        return None
    return message if isinstance(message, dict) and "type" in message else None
