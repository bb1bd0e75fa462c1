"""shadenet: shading networks, partially evaluated and compiled, from Python.

Compile a network (a ``.json`` network or a ``.mtlx`` MaterialX document, as a path or as
text), shade numpy arrays of fragments with it, render a scene into numpy layers, read and
write multi-layer EXR::

    import shadenet
    mat = shadenet.compile("examples/networks/marble.json")
    out = mat.shade(shadenet.grid(64, 64))      # {"color": (4096, 3) float32, ...}
    img = shadenet.render(res=(64, 36), spp=1)  # the embedded default scene
    img["layers"]["beauty"].shape               # (36, 64, 4)

The work runs in Rust (``shadenet._native``) with the GIL released; every error raises
:class:`ShadenetError` carrying shadenet's full message, bad arguments raise ``TypeError`` /
``ValueError``. The full reference is docs/python.md.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _native
from ._native import ShadenetError

__all__ = [
    "ShadenetError",
    "Material",
    "compile",
    "grid",
    "render",
    "Renderer",
    "frame_size",
    "write_exr",
    "read_exr",
    "FRAGMENT_FIELDS",
]

#: The fragment fields :meth:`Material.shade` accepts: key → values per fragment.
FRAGMENT_FIELDS: Dict[str, int] = {k: n for k, n, _ in _native.FRAGMENT_FIELDS}
_DTYPES: Dict[str, str] = {k: t for k, _, t in _native.FRAGMENT_FIELDS}

_U32_MAX = 0xFFFFFFFF

PathLike = Union[str, "os.PathLike[str]"]


def _path(value: Any, what: str) -> str:
    """``value`` as a filesystem path string, or ``TypeError`` naming ``what``."""
    if isinstance(value, (str, os.PathLike)):
        return os.fsdecode(os.fspath(value))
    raise TypeError(f"{what}: expected a str or os.PathLike path, got {type(value).__name__}")


def _opt_path(value: Any, what: str) -> Optional[str]:
    return None if value is None else _path(value, what)


def _opt_str(value: Any, what: str) -> Optional[str]:
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"{what}: expected a str, got {type(value).__name__}")


def _str_list(value: Any, what: str) -> Optional[List[str]]:
    """None, a comma-separated string or a sequence of strings, as a list of strings."""
    if value is None:
        return None
    if isinstance(value, str):
        return [v for v in value.split(",")]
    if isinstance(value, Sequence) and all(isinstance(v, str) for v in value):
        return list(value)
    raise TypeError(f"{what}: expected a list of str, got {value!r}")


def _floats(data: bytes, shape: Tuple[int, ...]) -> np.ndarray:
    """Little-endian f32 bytes from the native module as a writable float32 array."""
    return np.frombuffer(data, dtype="<f4").astype(np.float32).reshape(shape)


class Material:
    """A compiled material: a network linked, lowered and validated.

    Made by :func:`compile`. Compiling for a back end happens on the first
    :meth:`shade` with that back end and component mask and is cached.
    """

    __slots__ = ("_m",)

    def __init__(self, native: "_native.NativeMaterial") -> None:
        """Wraps a native material (use :func:`compile`)."""
        self._m = native

    @property
    def name(self) -> str:
        """The material's name: ``name=``, else the network's, else the file's stem."""
        return self._m.name

    @property
    def ir(self) -> str:
        """The optimized program's text form, as ``shadenet compile --emit ir`` prints it
        (specialized for every component and ray type, parameters baked)."""
        return self._m.ir

    @property
    def ir_before(self) -> str:
        """The program before optimization (``compile --emit ir:before``)."""
        return self._m.ir_before

    @property
    def stats(self) -> Dict[str, Any]:
        """What ``shadenet compile --stats`` reports, as a dict.

        Keys: ``ops_before``, ``ops_after``, ``rounds``, ``stop`` ("fixed point" or
        "budget exhausted"), ``optimize_s``, ``passes`` (a list of dicts: ``pass``,
        ``ops_before``, ``ops_after``, ``changes``, ``runs``, ``time_s``), ``needs`` (what
        the optimized program reads), ``report`` (the text ``--stats`` prints for the
        optimizer), ``jit`` (the JIT's compile statistics line, or why it would fall back
        to the interpreter) and, for ``.mtlx`` files, ``lobes`` (dicts: ``output``,
        ``kind``, ``component``, ``live``).
        """
        return self._m.stats()

    @property
    def outputs(self) -> List[Dict[str, Any]]:
        """The material's outputs, in order: dicts with ``name``, ``type`` (``color3``,
        ``float``…), ``components`` (the render components it has parts for) and
        ``channels`` (the channel names of its layers in :meth:`shade`'s result)."""
        return [
            {"name": n, "type": t, "components": list(c), "channels": list(ch)}
            for n, t, c, ch in self._m.outputs()
        ]

    @property
    def components(self) -> List[str]:
        """The render components the material declares (``diffuse``, ``specular``…)."""
        return list(self._m.components())

    def shade(
        self,
        fragments: Mapping[str, Any],
        *,
        lights: Optional[Sequence[str]] = None,
        backend: str = "jit",
        mask: Optional[Sequence[str]] = None,
    ) -> Dict[str, np.ndarray]:
        """Shades fragments; returns one float32 array per layer, shape (n, channels).

        ``fragments`` is a dict of arrays, one row per fragment (n rows): ``P`` (n, 3) is
        required; optional ``N``, ``Ng``, ``I``, ``dPdu``, ``dPdv``, ``dPdx``, ``dPdy``
        (n, 3), ``uv`` (n, 2), ``time`` (n,) and ``seed`` (n,) unsigned 32-bit integers.
        Defaults: ``N`` = (0, 0, 1); ``Ng`` = ``N``; ``I`` = ``P`` − (0, 0, 1.5) (the eye of
        :func:`grid`); ``dPdu`` = (1, 0, 0); ``dPdv`` = (0, 1, 0); ``uv``, ``dPdx``,
        ``dPdy`` and ``time`` zero; ``seed`` the row index. Every fragment is a camera ray
        of depth 0 (no scene: a BSDF-sampled ray sees black). Floats are converted to
        float32; every value must be finite. Wrong shapes, mismatched row counts, unknown
        keys and non-finite values raise ``ValueError`` naming the key.

        The result's keys are the layers ``shadenet shade -o x.exr`` writes: per output its
        total (``color``: every part summed) and each render component (``color.diffuse``);
        the channels of each are in :attr:`outputs`.

        ``lights``: light strings in the syntax of ``shadenet shade --light``
        (``point:X,Y,Z:I[:R,G,B]``, ``distant:DX,DY,DZ:I[:R,G,B]``,
        ``spot:X,Y,Z:DX,DY,DZ:I:CONE_DEG[:R,G,B]``, ``ambient:I[:R,G,B]``), added to the
        network's own light nodes, as the CLI adds them; with neither, the CLI's default
        light ``point:1,1,2:20``.

        ``backend``: ``"interp"`` (the interpreter), ``"jit"`` (Cranelift, one call per
        fragment), ``"jit-batch"`` (Cranelift's four-lane batch entry) or ``"gpu"`` (wgpu,
        one dispatch for all fragments). All agree with the CLI's back end of the same name
        bit for bit.

        ``mask``: the render components to compute (``None``: all); the material is
        specialized for them, as ``shadenet shade --components`` does.
        """
        if not isinstance(fragments, Mapping):
            raise TypeError(
                f"fragments: expected a dict of arrays, got {type(fragments).__name__}"
            )
        if not isinstance(backend, str):
            raise TypeError(f"backend: expected a str, got {type(backend).__name__}")
        n, fields = _fragment_bytes(fragments)
        layers = self._m.shade(
            n,
            fields,
            lights=_str_list(lights, "lights"),
            backend=backend,
            mask=_str_list(mask, "mask"),
        )
        return {name: _floats(data, (n, len(chans))) for name, chans, data in layers}

    def __repr__(self) -> str:
        return f"<shadenet.Material {self.name!r}: outputs {[o['name'] for o in self.outputs]}>"


def _fragment_bytes(fragments: Mapping[str, Any]) -> Tuple[int, Dict[str, bytes]]:
    """Checks the fragment arrays' shapes and converts them to the native module's bytes."""
    for key in fragments:
        if key not in FRAGMENT_FIELDS:
            raise ValueError(
                f'fragments: unknown key "{key}" (known: {", ".join(FRAGMENT_FIELDS)})'
            )
    if "P" not in fragments:
        raise ValueError('fragments: "P" is required (one row per fragment)')
    n: Optional[int] = None
    out: Dict[str, bytes] = {}
    for key in ["P"] + [k for k in fragments if k != "P"]:
        width = FRAGMENT_FIELDS[key]
        a = np.asarray(fragments[key])
        if a.dtype.kind not in "biuf":
            raise TypeError(f'fragments["{key}"]: expected numbers, got dtype {a.dtype}')
        if width == 1 and a.ndim == 2 and a.shape[1] == 1:
            a = a[:, 0]
        want = "(n,)" if width == 1 else f"(n, {width})"
        ok = a.ndim == 1 if width == 1 else (a.ndim == 2 and a.shape[1] == width)
        if not ok:
            raise ValueError(f'fragments["{key}"]: shape {a.shape}, expected {want}')
        if n is None:
            n = a.shape[0]
        elif a.shape[0] != n:
            raise ValueError(f'fragments["{key}"]: {a.shape[0]} rows, but "P" has {n}')
        if _DTYPES[key] == "u32":
            if a.dtype.kind not in "iu":
                raise TypeError(f'fragments["{key}"]: expected integers, got dtype {a.dtype}')
            if a.size and (a.min() < 0 or a.max() > _U32_MAX):
                raise ValueError(f'fragments["{key}"]: values must be 0 to 2**32 - 1')
            out[key] = np.ascontiguousarray(a, dtype="<u4").tobytes()
        else:
            out[key] = np.ascontiguousarray(a, dtype="<f4").tobytes()
    assert n is not None
    return n, out


def compile(
    source: PathLike,
    *,
    name: Optional[str] = None,
    mtlx_libraries: Optional[PathLike] = None,
    material: Optional[str] = None,
    output: Optional[str] = None,
) -> Material:
    """Compiles a network into a :class:`Material`.

    ``source`` is a path (str or os.PathLike) to a ``.json`` network or a ``.mtlx``
    MaterialX document, read exactly as the CLI reads it (relative texture paths are
    relative to the file's folder); or a str holding the JSON text of a network (it starts
    with ``{``, after whitespace) or the XML text of a MaterialX document (it starts with
    ``<``), whose relative texture paths are relative to the current directory at the time
    of the call. No temporary file is written.

    ``name`` renames the material. ``mtlx_libraries`` is the MaterialX ``libraries``
    folder (default: ``SHADENET_MTLX_LIBRARIES``, then each ``MATERIALX_SEARCH_PATH``
    entry's ``libraries/``). ``material`` / ``output`` select a material or an output of a
    MaterialX document (``shadenet shade --material`` / ``--mtlx-output``).

    Raises :class:`ShadenetError` for a missing, unreadable or malformed file or text (the
    message names the file or ``<network text>`` and the place), ``TypeError`` for a
    source of the wrong type.
    """
    if isinstance(source, str):
        head = source.lstrip()[:1]
        kind = "json" if head == "{" else "mtlx" if head == "<" else "path"
        text = source
    elif isinstance(source, os.PathLike):
        kind, text = "path", _path(source, "source")
    else:
        raise TypeError(
            f"source: expected a path or network text, got {type(source).__name__}"
        )
    native = _native.compile(
        text,
        kind,
        name=_opt_str(name, "name"),
        mtlx_libraries=_opt_path(mtlx_libraries, "mtlx_libraries"),
        material=_opt_str(material, "material"),
        output=_opt_str(output, "output"),
    )
    return Material(native)


def grid(width: int, height: int) -> Dict[str, np.ndarray]:
    """The fragments ``shadenet shade --res WIDTHxHEIGHT`` shades, as a fragments dict.

    A unit plane z = 0 seen from (0, 0, 1.5): pixel (x, y), row 0 at the top, is row
    ``y * width + x`` with ``uv = ((x + ½)/W, 1 − (y + ½)/H)``, ``P = (u − ½, v − ½, 0)``,
    ``N = Ng = +z``, ``I = P − eye``, ``dPdu = +x``, ``dPdv = +y``, one pixel of ray
    differentials, ``time`` 0 and ``seed`` the row. Every field is present, so
    ``material.shade(grid(w, h))`` shades exactly what the CLI shades.
    """
    for v, what in ((width, "width"), (height, "height")):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
            raise TypeError(f"{what}: expected an int, got {type(v).__name__}")
        if v < 1:
            raise ValueError(f"{what}: must be at least 1, got {v}")
    out: Dict[str, np.ndarray] = {}
    for key, data, cols, dtype in _native.grid(int(width), int(height)):
        if dtype == "u32":
            out[key] = np.frombuffer(data, dtype="<u4").astype(np.uint32)
        else:
            a = _floats(data, (-1, cols))
            out[key] = a[:, 0] if cols == 1 else a
    return out


def _check_render_options(res: Any, spp: Any, threads: Any, backend: Any) -> Optional[Tuple[int, int]]:
    """The checks :func:`render` and :class:`Renderer` share; returns ``res`` as ints."""
    if res is not None:
        if (
            not isinstance(res, Sequence)
            or len(res) != 2
            or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in res)
        ):
            raise TypeError(f"res: expected (width, height) ints, got {res!r}")
        if min(res) < 1 or max(res) > _U32_MAX:
            raise ValueError(f"res: {res[0]}x{res[1]} is not a resolution (1x1 and up)")
        res = (int(res[0]), int(res[1]))
    for v, what in ((spp, "spp"), (threads, "threads")):
        if v is not None and (not isinstance(v, (int, np.integer)) or isinstance(v, bool)):
            raise TypeError(f"{what}: expected an int, got {type(v).__name__}")
        if v is not None and not 1 <= v <= _U32_MAX:
            raise ValueError(f"{what}: must be 1 to 2**32 - 1, got {v}")
    if not isinstance(backend, str):
        raise TypeError(f"backend: expected a str, got {type(backend).__name__}")
    return res


def _crop(crop: Any) -> Optional[Tuple[int, int, int, int]]:
    """``crop`` as four ints ``(x0, y0, x1, y1)``, or ``TypeError``/``ValueError``."""
    if crop is None:
        return None
    if (
        not isinstance(crop, Sequence)
        or len(crop) != 4
        or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in crop)
    ):
        raise TypeError(f"crop: expected (x0, y0, x1, y1) ints, got {crop!r}")
    if min(crop) < 0 or max(crop) > _U32_MAX:
        raise ValueError(f"crop: {tuple(crop)} has a coordinate outside 0 to 2**32 - 1")
    return (int(crop[0]), int(crop[1]), int(crop[2]), int(crop[3]))


class Renderer:
    """A scene loaded and compiled once, rendered any number of times: the whole frame or a
    pixel window of it (``crop``) at a time.

    The arguments are :func:`render`'s. Compiling happens here (with the GIL released);
    :meth:`render` then only renders, so rendering a frame's tiles one by one pays the
    compile once (``shadenet.distributed`` keeps one per worker process).
    """

    __slots__ = ("_r",)

    def __init__(
        self,
        scene: Optional[PathLike] = None,
        *,
        spp: Optional[int] = None,
        res: Optional[Tuple[int, int]] = None,
        passes: Optional[Sequence[str]] = None,
        backend: str = "jit",
        threads: Optional[int] = None,
        mtlx_libraries: Optional[PathLike] = None,
    ) -> None:
        """Loads ``scene`` (``None``: the embedded default scene) with the overrides and
        compiles its materials."""
        res = _check_render_options(res, spp, threads, backend)
        self._r = _native.Renderer(
            _opt_path(scene, "scene"),
            spp=None if spp is None else int(spp),
            res=res,
            passes=_str_list(passes, "passes"),
            backend=backend,
            threads=None if threads is None else int(threads),
            mtlx_libraries=_opt_path(mtlx_libraries, "mtlx_libraries"),
        )

    @property
    def frame(self) -> Tuple[int, int]:
        """The full frame's size ``(width, height)``."""
        return tuple(self._r.frame)  # type: ignore[return-value]

    @property
    def spp(self) -> int:
        """Samples per pixel."""
        return self._r.spp

    def render(self, crop: Optional[Tuple[int, int, int, int]] = None) -> Dict[str, Any]:
        """Renders the frame, or only the pixel window ``crop = (x0, y0, x1, y1)``: columns
        x0..x1 and rows y0..y1 from the top left, ends exclusive. Every pixel of a window
        has exactly the bits a full render gives it. Returns :func:`render`'s dict; its
        layers cover the window, ``window`` is the window and ``frame`` the full size.
        A window that is empty or reaches outside the frame is a ``ValueError``.
        """
        width, height, layers, stats, window, frame = self._r.render(_crop(crop))
        return {
            "layers": {n: _floats(d, (height, width, len(c))) for n, c, d in layers},
            "channels": {n: list(c) for n, c, _ in layers},
            "stats": dict(stats),
            "window": tuple(window),
            "frame": tuple(frame),
        }


def render(
    scene: Optional[PathLike] = None,
    *,
    spp: Optional[int] = None,
    res: Optional[Tuple[int, int]] = None,
    crop: Optional[Tuple[int, int, int, int]] = None,
    passes: Optional[Sequence[str]] = None,
    backend: str = "jit",
    threads: Optional[int] = None,
    mtlx_libraries: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Renders a scene and returns its layers, as ``shadenet render -o x.exr`` writes them.

    ``scene``: a scene file (``.toml``, docs/scene-format.md); ``None`` renders the
    embedded default scene. ``spp``, ``res`` (``(width, height)``), ``crop`` (``(x0, y0,
    x1, y1)``, ends exclusive: only that pixel window, as ``--crop``) and ``passes`` (a list
    of names, or a comma-separated str) override the scene's as ``--spp``, ``--res`` and
    ``--passes`` do. ``backend``: ``"interp"``, ``"jit"`` or ``"gpu"``. ``threads``:
    worker threads, 1 to 8 × the cores (default: all cores). ``mtlx_libraries``: the
    MaterialX libraries folder for ``mtlx = "…"`` materials.

    Returns a dict: ``layers`` (layer name → float32 array, shape (height, width,
    channels) of the window: ``beauty`` first, then the passes), ``channels`` (layer name →
    channel names, ``["R", "G", "B", "A"]`` for ``beauty``), ``window`` (``(x0, y0, x1,
    y1)``), ``frame`` (``(width, height)`` of the full frame), ``stats`` (``spp``,
    ``threads``, ``backend``, ``setup_s``, ``compile_s``, ``bvh_s``, ``render_s``,
    ``shaders``, ``triangles``, ``rays``, ``camera_rays``, ``shadow_rays``,
    ``secondary_rays``, ``shading_calls``, ``nonfinite``, ``batches``,
    ``batched_fragments``, ``warnings``). One call is :class:`Renderer` then
    :meth:`Renderer.render`.

    Raises :class:`ShadenetError` when the scene or a material cannot be loaded,
    ``ValueError`` for an option out of range or a crop outside the frame.
    """
    crop = _crop(crop)
    r = Renderer(
        scene,
        spp=spp,
        res=res,
        passes=passes,
        backend=backend,
        threads=threads,
        mtlx_libraries=mtlx_libraries,
    )
    return r.render(crop)


def frame_size(
    scene: Optional[PathLike] = None, *, res: Optional[Tuple[int, int]] = None
) -> Tuple[int, int]:
    """The frame size ``(width, height)`` a render of ``scene`` (``None``: the embedded
    default scene) with ``res`` would have: the scene is loaded and checked, nothing is
    compiled. Raises :class:`ShadenetError` for a scene that cannot be loaded."""
    res = _check_render_options(res, None, None, "jit")
    return tuple(_native.frame_size(_opt_path(scene, "scene"), res=res))  # type: ignore[return-value]


#: Default channel names by channel count (:func:`write_exr`).
_DEFAULT_CHANNELS = {1: ["Y"], 2: ["X", "Y"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}

#: The order of channels within a layer in :func:`read_exr`: colour, then vector, then uv;
#: other names after these, alphabetically.
_CHANNEL_ORDER = {c: i for i, c in enumerate(["R", "G", "B", "A", "X", "Y", "Z", "W", "U", "V"])}


def write_exr(
    path: PathLike,
    layers: Mapping[str, Any],
    channels: Optional[Mapping[str, Sequence[str]]] = None,
) -> None:
    """Writes layers to one multi-layer float32 EXR, atomically (temporary file + rename:
    on error an existing file is left untouched).

    ``layers``: layer name → array of shape (height, width, channels) or (height, width),
    every layer the same size. Each channel is written as ``layer.channel``; the channel
    names are ``channels[layer]`` when given, else by count: ``Y``; ``X Y``; ``R G B``;
    ``R G B A``. An empty channel name writes the channel under the layer name alone.
    ``write_exr(path, **{k: r[k] for k in ("layers", "channels")})`` writes what
    :func:`render` returned, and a :func:`read_exr` result round-trips.
    """
    out_path = _path(path, "path")
    if not isinstance(layers, Mapping) or not layers:
        raise ValueError("layers: expected a non-empty dict of arrays")
    size: Optional[Tuple[int, int]] = None
    flat: List[Tuple[str, bytes]] = []
    for name, value in layers.items():
        a = np.asarray(value)
        if a.dtype.kind not in "biuf":
            raise TypeError(f'layers["{name}"]: expected numbers, got dtype {a.dtype}')
        if a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3:
            raise ValueError(
                f'layers["{name}"]: shape {a.shape}, expected (height, width, channels)'
            )
        if size is None:
            size = (a.shape[0], a.shape[1])
        elif (a.shape[0], a.shape[1]) != size:
            raise ValueError(
                f'layers["{name}"]: {a.shape[1]}x{a.shape[0]}, but the first layer is '
                f"{size[1]}x{size[0]}"
            )
        names = None if channels is None else channels.get(name)
        if names is None:
            names = _DEFAULT_CHANNELS.get(a.shape[2])
            if names is None:
                raise ValueError(
                    f'layers["{name}"]: {a.shape[2]} channels: name them with channels='
                )
        names = list(names)
        if len(names) != a.shape[2]:
            raise ValueError(
                f'channels["{name}"]: {len(names)} names for {a.shape[2]} channels'
            )
        for c, cname in enumerate(names):
            full = f"{name}.{cname}" if cname else name
            flat.append((full, np.ascontiguousarray(a[:, :, c], dtype="<f4").tobytes()))
    assert size is not None
    _native.write_exr(out_path, size[1], size[0], flat)


def read_exr(path: PathLike) -> Dict[str, Any]:
    """Reads the first part of an EXR file, every sample as float32.

    Channels are grouped into layers by the part of their name before the last ``.``
    (``beauty.R`` → layer ``beauty``, channel ``R``; a name without ``.`` is a layer of
    one channel named ``""``). Returns a dict: ``layers`` (layer name → float32 array of
    shape (height, width, channels)) and ``channels`` (layer name → channel names, ordered
    R G B A, X Y Z W, U V, then the others alphabetically), the form :func:`render`
    returns.
    """
    width, height, chans = _native.read_exr(_path(path, "path"))
    groups: Dict[str, List[Tuple[str, bytes]]] = {}
    for full, data in chans:
        layer, _, cname = full.rpartition(".")
        if not layer:
            layer, cname = full, ""
        groups.setdefault(layer, []).append((cname, data))
    layers: Dict[str, np.ndarray] = {}
    names: Dict[str, List[str]] = {}
    for layer, items in groups.items():
        items.sort(key=lambda it: (_CHANNEL_ORDER.get(it[0], len(_CHANNEL_ORDER)), it[0]))
        names[layer] = [c for c, _ in items]
        planes = [_floats(d, (height, width)) for _, d in items]
        layers[layer] = np.stack(planes, axis=-1)
    return {"layers": layers, "channels": names}
