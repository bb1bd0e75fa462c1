"""Type stubs of ``shadenet._native``, the Rust extension (PyO3, abi3).

Use the ``shadenet`` package instead: it converts numpy arrays to the little-endian bytes
this module takes and back. Arrays cross as ``bytes`` of f32 (seeds: u32) with their
shapes beside them, so the extension does not depend on numpy's C API.
"""

from typing import Dict, List, Optional, Tuple

class ShadenetError(Exception):
    """An error from shadenet; the message is the full chain of causes, outermost first."""

#: ``(key, values per fragment, "f32" | "u32")`` for every fragment field.
FRAGMENT_FIELDS: List[Tuple[str, int, str]]

class NativeMaterial:
    """A compiled material (``shadenet.Material`` wraps it)."""

    @property
    def name(self) -> str:
        """The material's name."""
    @property
    def ir(self) -> str:
        """The optimized program's text form (``compile --emit ir``)."""
    @property
    def ir_before(self) -> str:
        """The unoptimized program's text form (``compile --emit ir:before``)."""
    def stats(self) -> Dict[str, object]:
        """What ``compile --stats`` reports."""
    def outputs(self) -> List[Tuple[str, str, List[str], List[str]]]:
        """``(name, type, components, channels)`` per output."""
    def components(self) -> List[str]:
        """The render components the program declares."""
    def shade(
        self,
        n: int,
        fields: Dict[str, bytes],
        lights: Optional[List[str]] = None,
        backend: str = "jit",
        mask: Optional[List[str]] = None,
    ) -> List[Tuple[str, List[str], bytes]]:
        """Shades ``n`` fragments; ``(layer, channels, n × channels f32 bytes)`` each."""

def compile(
    source: str,
    kind: str,
    name: Optional[str] = None,
    mtlx_libraries: Optional[str] = None,
    material: Optional[str] = None,
    output: Optional[str] = None,
) -> NativeMaterial:
    """Compiles a network; ``kind`` is ``"path"``, ``"json"`` or ``"mtlx"``."""

def grid(width: int, height: int) -> List[Tuple[str, bytes, int, str]]:
    """The ``shade`` grid's fields: ``(key, bytes, values per fragment, dtype)``."""

class Renderer:
    """A scene loaded and compiled once, rendered whole or a pixel window at a time."""

    frame: Tuple[int, int]
    spp: int
    def __init__(
        self,
        scene: Optional[str] = None,
        spp: Optional[int] = None,
        res: Optional[Tuple[int, int]] = None,
        passes: Optional[List[str]] = None,
        backend: str = "jit",
        threads: Optional[int] = None,
        mtlx_libraries: Optional[str] = None,
    ) -> None: ...
    def render(
        self, crop: Optional[Tuple[int, int, int, int]] = None
    ) -> Tuple[
        int,
        int,
        List[Tuple[str, List[str], bytes]],
        Dict[str, object],
        Tuple[int, int, int, int],
        Tuple[int, int],
    ]:
        """``(width, height, [(layer, channels, h × w × c f32 bytes)], stats, window, frame)``."""

def frame_size(scene: Optional[str] = None, res: Optional[Tuple[int, int]] = None) -> Tuple[int, int]:
    """The frame size of a scene with the ``res`` override (nothing compiled)."""

def write_exr(path: str, width: int, height: int, channels: List[Tuple[str, bytes]]) -> None:
    """Writes ``width × height`` f32 channels to an EXR, atomically."""

def read_exr(path: str) -> Tuple[int, int, List[Tuple[str, bytes]]]:
    """Reads an EXR's first part: ``(width, height, [(channel, f32 bytes)])``."""
