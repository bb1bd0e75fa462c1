"""Rendering across machines on Ray: one task per tile of a frame, or per frame of a sequence.

We do not schedule anything ourselves: Ray places the tasks on its workers, retries a task
whose worker process died, and runs a local cluster for tests (``ray.init()`` on this
machine's cores). This module splits the work, streams finished tiles back to the driver
with a progress line, checks that every tile arrives exactly once, assembles the frame and
writes the EXR atomically.

**Where the scene comes from.** Workers read the scene file and its assets (meshes, network
files, textures, environment maps) at the *same path* as the driver: on one machine that is
always so; on a cluster the scene must sit on a file system every node mounts at the same
place (NFS, a shared volume). The driver checks the path first; a worker that cannot read it
fails its task with our error naming the host and the path, and nothing is written. The
embedded default scene (``scene=None``) needs no files at all.

**What scales.** Tiles of one frame (``tiles=N`` or ``tile_size=S``): every pixel is rendered
by exactly one task, and a tile's pixels carry the bits a single-process render gives them,
so the assembled EXR is bit-identical to ``shadenet render``. Frames of a sequence
(``frames=[...]``): one task per frame. Each worker process keeps the compiled scene between
its tasks (the JIT compiles a scene's materials once per process, not once per tile).

Command line::

    python -m shadenet.distributed SCENE.toml -o out.exr --tiles 16 [--address ray://host:10001]
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

import shadenet

#: Test-only switch: ``"K:MARKER"`` makes the first attempt of tile ``K`` exit its worker
#: process abruptly (as a killed machine would) unless the file ``MARKER`` exists; the
#: attempt creates it first, so Ray's retry of the task succeeds.
FAIL_TILE_ENV = "SHADENET_TEST_FAIL_TILE"

Window = Tuple[int, int, int, int]


def split_frame(
    width: int, height: int, tiles: Optional[int] = None, tile_size: Optional[int] = None
) -> List[Window]:
    """Cut a ``width × height`` frame into windows ``(x0, y0, x1, y1)`` (ends exclusive) that
    tile it exactly, row by row from the top left.

    ``tiles=N`` makes ``N`` tiles in a grid as close to square tiles as ``N``'s divisors allow
    (a prime ``N`` gives strips); ``tile_size=S`` makes ``S × S`` tiles (smaller at the right
    and bottom edges). Give one of the two.
    """
    if width < 1 or height < 1:
        raise ValueError(f"frame {width}×{height}: expected a size of at least 1×1")
    if (tiles is None) == (tile_size is None):
        raise ValueError("give exactly one of tiles=N or tile_size=S")
    if tiles is not None:
        if not isinstance(tiles, int) or tiles < 1 or tiles > width * height:
            raise ValueError(
                f"tiles={tiles!r}: expected a whole number from 1 to the frame's "
                f"{width * height} pixels"
            )
        # Columns: the divisor of N that makes tiles closest to square.
        ideal = math.sqrt(tiles * width / height)
        divisors = [d for d in range(1, tiles + 1) if tiles % d == 0]
        fits = [d for d in divisors if d <= width and tiles // d <= height] or [1]
        cols = min(fits, key=lambda d: abs(math.log(d / ideal)))
        rows = tiles // cols
        xs = [width * i // cols for i in range(cols + 1)]
        ys = [height * j // rows for j in range(rows + 1)]
    else:
        if not isinstance(tile_size, int) or tile_size < 1:
            raise ValueError(f"tile_size={tile_size!r}: expected a whole number ≥ 1")
        xs = list(range(0, width, tile_size)) + [width]
        ys = list(range(0, height, tile_size)) + [height]
    return [
        (xs[i], ys[j], xs[i + 1], ys[j + 1])
        for j in range(len(ys) - 1)
        for i in range(len(xs) - 1)
    ]


@dataclass
class Job:
    """What every task of one frame renders: the scene (a path, or ``None`` for the embedded
    default scene) and the render options."""

    scene: Optional[str]
    spp: Optional[int] = None
    res: Optional[Tuple[int, int]] = None
    passes: Optional[List[str]] = None
    backend: str = "jit"
    threads: Optional[int] = None
    mtlx_libraries: Optional[str] = None

    def key(self) -> Tuple[Any, ...]:
        """The worker-side cache key: the options, and the scene file's identity (path,
        modification time, size) so an edited scene is compiled afresh."""
        ident: Tuple[Any, ...] = ()
        if self.scene is not None:
            st = os.stat(self.scene)
            ident = (st.st_mtime_ns, st.st_size)
        return (
            self.scene,
            ident,
            self.spp,
            self.res,
            tuple(self.passes or ()),
            self.backend,
            self.threads,
            self.mtlx_libraries,
        )


# One compiled scene per worker process, reused by its later tasks.
_CACHE: Dict[Tuple[Any, ...], Any] = {}


def _renderer(job: Job) -> Any:
    key = job.key()
    r = _CACHE.get(key)
    if r is None:
        _CACHE.clear()
        r = shadenet.Renderer(
            job.scene,
            spp=job.spp,
            res=job.res,
            passes=job.passes,
            backend=job.backend,
            threads=job.threads,
            mtlx_libraries=job.mtlx_libraries,
        )
        _CACHE[key] = r
    return r


def _maybe_fail(index: int) -> None:
    """The test-only failure switch (:data:`FAIL_TILE_ENV`)."""
    spec = os.environ.get(FAIL_TILE_ENV)
    if not spec:
        return
    tile, _, marker = spec.partition(":")
    if tile.strip() == str(index) and marker and not os.path.exists(marker):
        with open(marker, "w") as f:
            f.write(f"tile {index} failed its first attempt in process {os.getpid()}\n")
        os._exit(17)


def _tile_task(job: Job, index: int, window: Optional[Window], ledger: Any) -> Dict[str, Any]:
    """One task: render ``window`` of the job's frame (``None``: the whole frame)."""
    import ray

    ray.get(ledger.start.remote(index, socket.gethostname(), os.getpid()))
    _maybe_fail(index)
    if job.scene is not None and not os.access(job.scene, os.R_OK):
        raise shadenet.ShadenetError(
            f"worker on {socket.gethostname()} cannot read the scene {job.scene}: the "
            "workers read scenes at the driver's path (a file system every node mounts)"
        )
    t0 = time.perf_counter()
    result = _renderer(job).render(crop=window)
    return {
        "index": index,
        "window": window,
        "layers": result["layers"],
        "channels": result["channels"],
        "frame": result["frame"],
        "seconds": time.perf_counter() - t0,
        "host": socket.gethostname(),
        "pid": os.getpid(),
    }


class _Ledger:
    """Counts the attempts of each task (a Ray actor): a task's later attempts are Ray's
    retries, which the driver reports."""

    def __init__(self) -> None:
        self.attempts: Dict[int, List[Tuple[str, int]]] = {}

    def start(self, index: int, host: str, pid: int) -> None:
        self.attempts.setdefault(index, []).append((host, pid))

    def report(self) -> Dict[int, List[Tuple[str, int]]]:
        return self.attempts


@dataclass
class Result:
    """A distributed render's outcome.

    ``layers`` maps each layer to a float32 array ``(height, width, channels)`` (one frame;
    empty for a sequence), ``channels`` each layer's channel names, ``outputs`` the files
    written, ``retries`` the tasks Ray ran more than once (task index → the attempts'
    ``(host, pid)``), ``task_seconds`` each task's render time inside its worker, ``wall``
    the driver's time from submission to the last result, ``overhead_ms`` the mean per-task
    time outside rendering (``wall × workers / tasks − mean task time``, in ms).
    """

    layers: Dict[str, np.ndarray] = field(default_factory=dict)
    channels: Dict[str, List[str]] = field(default_factory=dict)
    outputs: List[str] = field(default_factory=list)
    tasks: int = 0
    retries: Dict[int, List[Tuple[str, int]]] = field(default_factory=dict)
    task_seconds: List[float] = field(default_factory=list)
    wall: float = 0.0
    workers: int = 0
    overhead_ms: float = 0.0


def _progress_printer(enabled: bool, total: int, what: str) -> Callable[[int], None]:
    start = time.perf_counter()

    def show(done: int) -> None:
        if not enabled:
            return
        el = time.perf_counter() - start
        eta = el / done * (total - done) if done else float("nan")
        bar = "=" * (30 * done // total) + " " * (30 - 30 * done // total)
        end = "\n" if done == total else ""
        sys.stderr.write(f"\rrendering [{bar}] {done}/{total} {what}, {el:.1f} s (eta {eta:.1f} s){end}")
        sys.stderr.flush()

    return show


def render(
    scene: Optional[str | os.PathLike] = None,
    output: Optional[str | os.PathLike] = None,
    *,
    tiles: Optional[int] = None,
    tile_size: Optional[int] = None,
    frames: Optional[Sequence[str | os.PathLike]] = None,
    address: Optional[str] = None,
    spp: Optional[int] = None,
    res: Optional[Tuple[int, int]] = None,
    passes: Optional[List[str]] = None,
    backend: str = "jit",
    threads_per_task: int = 1,
    max_retries: int = 3,
    progress: Optional[bool] = None,
    mtlx_libraries: Optional[str | os.PathLike] = None,
) -> Result:
    """Render on a Ray cluster and write the EXR(s).

    One frame (``scene``; ``None`` is the embedded default scene) split into ``tiles=N`` or
    ``tile_size=S`` tiles, one Ray task each, assembled on the driver into ``output``
    (default ``render.exr``): bit-identical to ``shadenet render``. Or a sequence
    (``frames=[scene files]``), one task per frame; ``output`` is then a pattern with
    ``{stem}`` (the scene file's name without extension) or ``{index}`` (default
    ``"{stem}.exr"``).

    ``address`` is the cluster (``"ray://host:10001"`` or ``"auto"``); without it, and when
    Ray is not initialised yet, a local cluster on this machine's cores. Each task takes
    ``threads_per_task`` CPUs and render threads; a task whose worker process dies is run
    again up to ``max_retries`` times (reported in :attr:`Result.retries`); an error in the
    scene or the options is not retried and raises :class:`shadenet.ShadenetError` naming the
    task. ``progress`` (default: when stderr is a terminal) prints a progress line.
    Nothing is written unless every task succeeded.
    """
    import ray

    if frames is not None and (scene is not None or tiles is not None or tile_size is not None):
        raise ValueError("frames=[...] renders whole frames: give no scene, tiles or tile_size")
    if frames is None and tiles is None and tile_size is None:
        raise ValueError("give tiles=N or tile_size=S (one frame), or frames=[scene files]")
    if not isinstance(threads_per_task, int) or threads_per_task < 1:
        raise ValueError(f"threads_per_task={threads_per_task!r}: expected a whole number ≥ 1")
    scenes = [scene] if frames is None else list(frames)
    if frames is not None and not scenes:
        raise ValueError("frames=[]: no scene files to render")
    for s in scenes:
        if s is not None and not os.access(os.fspath(s), os.R_OK):
            raise shadenet.ShadenetError(f"cannot read the scene {os.fspath(s)}")
    jobs = [
        Job(
            scene=None if s is None else os.path.abspath(os.fspath(s)),
            spp=spp,
            res=None if res is None else (int(res[0]), int(res[1])),
            passes=passes,
            backend=backend,
            threads=threads_per_task,
            mtlx_libraries=None if mtlx_libraries is None else os.fspath(mtlx_libraries),
        )
        for s in scenes
    ]
    # Check the options and learn the frame size on the driver before any task runs.
    sizes = [shadenet.frame_size(j.scene, res=j.res) for j in jobs]
    if frames is None:
        windows: List[Tuple[int, Optional[Window]]] = [
            (0, w) for w in split_frame(*sizes[0], tiles=tiles, tile_size=tile_size)
        ]
        outputs = [os.fspath(output) if output is not None else "render.exr"]
    else:
        windows = [(k, None) for k in range(len(jobs))]
        pattern = os.fspath(output) if output is not None else "{stem}.exr"
        outputs = [
            pattern.format(stem=os.path.splitext(os.path.basename(j.scene or "default"))[0], index=k)
            for k, j in enumerate(jobs)
        ]
        if len(set(outputs)) != len(outputs):
            raise ValueError(f"output pattern {pattern!r} names two frames the same file")

    if not ray.is_initialized():
        ray.init(address=address, log_to_driver=False, include_dashboard=False)
    workers = max(1, int(ray.cluster_resources().get("CPU", 1)) // threads_per_task)
    ledger = ray.remote(num_cpus=0)(_Ledger).remote()
    options: Dict[str, Any] = dict(
        num_cpus=threads_per_task, max_retries=max_retries, retry_exceptions=False
    )
    if os.environ.get(FAIL_TILE_ENV):
        # The test-only switch reaches the workers from the driver's environment.
        options["runtime_env"] = {"env_vars": {FAIL_TILE_ENV: os.environ[FAIL_TILE_ENV]}}
    task = ray.remote(_tile_task).options(**options)
    show = _progress_printer(
        sys.stderr.isatty() if progress is None else progress,
        len(windows),
        "tiles" if frames is None else "frames",
    )
    t0 = time.perf_counter()
    pending = {
        task.remote(jobs[j], i, w, ledger): i for i, (j, w) in enumerate(windows)
    }
    done: Dict[int, Dict[str, Any]] = {}
    show(0)
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        for ref in ready:
            i = pending.pop(ref)
            try:
                done[i] = ray.get(ref)
            except ray.exceptions.RayTaskError as e:
                raise shadenet.ShadenetError(f"task {i} ({_what(windows[i][1])}): {e.cause}") from None
            except ray.exceptions.RayError as e:
                raise shadenet.ShadenetError(
                    f"task {i} ({_what(windows[i][1])}) failed after {max_retries} retries: {e}"
                ) from None
            show(len(done))
    wall = time.perf_counter() - t0
    attempts = ray.get(ledger.report.remote())
    result = Result(
        outputs=outputs,
        tasks=len(windows),
        retries={k: v for k, v in attempts.items() if len(v) > 1},
        task_seconds=[done[i]["seconds"] for i in range(len(windows))],
        wall=wall,
        workers=workers,
    )
    result.overhead_ms = 1e3 * max(
        0.0, wall * min(workers, len(windows)) / len(windows) - float(np.mean(result.task_seconds))
    )
    if frames is None:
        result.layers, result.channels = _assemble(sizes[0], [done[i] for i in range(len(windows))])
        shadenet.write_exr(outputs[0], result.layers, channels=result.channels)
    else:
        for i, path in enumerate(outputs):
            shadenet.write_exr(path, done[i]["layers"], channels=done[i]["channels"])
    return result


def _what(window: Optional[Window]) -> str:
    return "the whole frame" if window is None else "tile %d,%d,%d,%d" % window


def _assemble(
    size: Tuple[int, int], parts: List[Dict[str, Any]]
) -> Tuple[Dict[str, np.ndarray], Dict[str, List[str]]]:
    """The frame from its tiles: every pixel written by exactly one tile (checked)."""
    width, height = size
    owner = np.zeros((height, width), dtype=np.int32)
    layers: Dict[str, np.ndarray] = {}
    channels = parts[0]["channels"]
    for p in parts:
        x0, y0, x1, y1 = p["window"]
        owner[y0:y1, x0:x1] += 1
        if p["channels"] != channels:
            raise shadenet.ShadenetError(f"task {p['index']} returned other layers than task 0")
        for name, data in p["layers"].items():
            if name not in layers:
                layers[name] = np.zeros((height, width, data.shape[2]), dtype=np.float32)
            layers[name][y0:y1, x0:x1, :] = data
    if not (owner == 1).all():
        raise shadenet.ShadenetError(
            f"internal error: {(owner == 0).sum()} pixels missing and {(owner > 1).sum()} "
            "covered twice after assembling the tiles"
        )
    return layers, channels


def main(argv: Optional[List[str]] = None) -> int:
    """``python -m shadenet.distributed``: the command-line entry."""
    ap = argparse.ArgumentParser(
        prog="python -m shadenet.distributed",
        description="Render a scene on a Ray cluster, one task per tile (or per frame).",
    )
    ap.add_argument("scene", nargs="*", help="scene file (.toml); several with --frames; none: the embedded default scene")
    ap.add_argument("-o", "--output", help="output EXR (default render.exr; with --frames a pattern with {stem} or {index})")
    ap.add_argument("--tiles", type=int, help="split the frame into this many tiles")
    ap.add_argument("--tile-size", type=int, help="split the frame into tiles of this many pixels a side")
    ap.add_argument("--frames", action="store_true", help="the scenes are the frames of a sequence: one task per frame")
    ap.add_argument("--address", help="the Ray cluster (ray://host:10001 or auto; default: a local cluster)")
    ap.add_argument("--spp", type=int, help="samples per pixel (overrides the scene)")
    ap.add_argument("--res", help="resolution WxH (overrides the scene)")
    ap.add_argument("--passes", help="passes, comma separated (replace the scene's)")
    ap.add_argument("--backend", default="jit", choices=["interp", "jit"], help="the back end (default jit)")
    ap.add_argument("--threads-per-task", type=int, default=1, help="CPUs and render threads per task (default 1)")
    ap.add_argument("--max-retries", type=int, default=3, help="retries of a task whose worker died (default 3)")
    ap.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    a = ap.parse_args(argv)
    res = None
    if a.res:
        try:
            w, h = a.res.lower().split("x")
            res = (int(w), int(h))
        except ValueError:
            ap.error(f"--res {a.res}: expected WxH")
    try:
        if a.frames:
            if not a.scene:
                ap.error("--frames needs the scene files")
            r = render(frames=a.scene, output=a.output, address=a.address, spp=a.spp, res=res,
                       passes=a.passes.split(",") if a.passes else None, backend=a.backend,
                       threads_per_task=a.threads_per_task, max_retries=a.max_retries,
                       progress=None if not a.quiet else False)
        else:
            if len(a.scene) > 1:
                ap.error("several scenes: add --frames to render them as a sequence")
            if a.tiles is None and a.tile_size is None:
                a.tiles = 16
            r = render(a.scene[0] if a.scene else None, a.output, tiles=a.tiles,
                       tile_size=a.tile_size, address=a.address, spp=a.spp, res=res,
                       passes=a.passes.split(",") if a.passes else None, backend=a.backend,
                       threads_per_task=a.threads_per_task, max_retries=a.max_retries,
                       progress=None if not a.quiet else False)
    except (shadenet.ShadenetError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    if not a.quiet:
        mean = float(np.mean(r.task_seconds))
        print(
            f"{r.tasks} tasks on {r.workers} workers in {r.wall:.3f} s ({r.tasks / r.wall:.1f} tasks/s); "
            f"mean task {mean * 1e3:.1f} ms, overhead ≈ {r.overhead_ms:.1f} ms per task"
        )
        for k, att in sorted(r.retries.items()):
            print(f"task {k} was retried: {len(att) - 1} attempt(s) lost ({', '.join(f'{h} pid {p}' for h, p in att)})")
        for o in r.outputs:
            print(f"wrote {o}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
