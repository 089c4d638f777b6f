"""`python -m caustic_farm SCENE... -o OUT_PATTERN`: render frames on a Dask cluster.

JSON lines of progress go to stdout (`start`, `chunk`, `retry`, `frame`, `cancelling`,
`summary`, or one `error`); Dask's own logs go to stderr. Exit codes follow the binary's
(docs/contract.md): 0 done, 1 internal (a chunk failed every attempt), 2 bad settings,
3 bad scene, 4 I/O, 5 cancelled with partial frames written, 6 cancelled before any, 7 memory.
"""

import argparse
import signal
import sys
import threading

from .driver import FarmError, json_lines, render_frames


def parse(argv):
    p = argparse.ArgumentParser(prog="caustic_farm", description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="+", help="scene files, one per frame, in frame order")
    p.add_argument("-o", "--output", required=True,
                   help="output path; with several scenes a pattern with {frame} (e.g. out/f{frame:04d}.exr)")
    p.add_argument("--spp", type=int, help="samples per pixel of each frame [default: the scene's, else 64]")
    p.add_argument("--chunks", type=int, default=4, help="sample chunks per frame [default: 4]")
    p.add_argument("--scheduler", help="Dask scheduler address (tcp://host:8786, tls://...); "
                                       "default: a LocalCluster on 127.0.0.1")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster workers (without --scheduler) [default: 2]")
    p.add_argument("--binary", help="caustic binary on the workers [default: CAUSTIC_BINARY there, else PATH]")
    p.add_argument("--attempts", type=int, default=3, help="tries per chunk before the run fails [default: 3]")
    p.add_argument("--photon-maps", choices=("frame", "chunk"), default="frame",
                   help="Jensen photon mapping: one map per frame, shared by its chunks (exact), or one per "
                        "chunk (independent estimates) [default: frame]")
    p.epilog = "Flags after -- go to every `caustic render` (e.g. -- --integrator bdpt --resolution 640x360)."
    # Split at the first "--" by hand: argparse would let the scenes swallow everything.
    render_args = []
    if "--" in argv:
        at = argv.index("--")
        argv, render_args = argv[:at], argv[at + 1:]
    args = p.parse_args(argv)
    args.render_args = render_args
    return args


def outputs_for(pattern, n):
    """Output paths: the pattern formatted with frame=i (required when there are several frames)."""
    if n > 1 and "{frame" not in pattern:
        raise FarmError(2, "several scenes need an output pattern with {frame}, e.g. out/f{frame:04d}.exr")
    try:
        return [pattern.format(frame=i) for i in range(n)]
    except (KeyError, IndexError, ValueError) as err:
        raise FarmError(2, f"bad output pattern {pattern!r}: {err}") from None


def main(argv=None):
    report = json_lines()
    try:
        args = parse(sys.argv[1:] if argv is None else argv)
    except SystemExit as e:
        return 2 if e.code else 0
    cancel = threading.Event()

    def on_signal(signum, frame):
        if cancel.is_set():
            raise KeyboardInterrupt  # second signal: leave at once (the cluster still shuts down)
        cancel.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        outputs = outputs_for(args.output, len(args.scenes))
        result = render_frames(args.scenes, outputs, spp=args.spp, chunks=args.chunks, binary=args.binary,
                               extra_args=args.render_args, scheduler=args.scheduler, workers=args.workers,
                               max_attempts=args.attempts, report=report, cancel=cancel,
                               photon_maps=args.photon_maps)
        return result.code
    except FarmError as err:
        report({"type": "error", "code": err.code, "message": str(err)})
        return err.code
    except KeyboardInterrupt:
        report({"type": "error", "code": 6, "message": "interrupted twice: left without merging"})
        return 6
