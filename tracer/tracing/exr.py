"""Named (H, W) float channels and header attributes -> one multilayer OpenEXR file, atomically; and back.

The channels are written under exactly the names the caller gives: a multilayer file's names are dotted,
`<view layer>.<pass>.<channel>` as Blender writes them ("ViewLayer.Combined.R", "ViewLayer.Depth.Z",
"ViewLayer.CryptoObject00.R") or without the view layer ("Combined.R"); plain "R", "G", "B", "A" are the beauty
image of a single-layer file. Written with the official OpenEXR Python bindings (3.x), ZIP compression, one
scanline part; 32-bit float unless a channel is named in `half`.

The bindings are imported only when a file is written or read: the tracer itself runs without them.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType

import numpy as np

from tracer.tracing.images import atomic_path

INSTALL_HINT = "pip install OpenEXR (3.x), or the project's extra: pip install -e '.[exr]'"

# Attributes the writer sets itself from the channels and its own settings; a caller's header may not set them.
RESERVED_ATTRIBUTES = frozenset(
    {
        "channels",
        "compression",
        "dataWindow",
        "displayWindow",
        "lineOrder",
        "pixelAspectRatio",
        "screenWindowCenter",
        "screenWindowWidth",
        "type",
        "tiles",
    }
)


def openexr_module() -> ModuleType:
    """The OpenEXR bindings module, or an ImportError that says how to install them."""
    try:
        import OpenEXR
    except ImportError as error:
        raise ImportError(f"OpenEXR files need the OpenEXR Python bindings: {INSTALL_HINT}") from error
    if not hasattr(OpenEXR, "File"):
        raise ImportError(f"the installed OpenEXR bindings are older than 3.3 (no OpenEXR.File): {INSTALL_HINT}")
    return OpenEXR


def write_multilayer_exr(
    path: Path,
    channels: Mapping[str, np.ndarray],
    header: Mapping[str, str] | None = None,
    half: set[str] | None = None,
) -> None:
    """Writes channels into the OpenEXR file at path, replacing it only once the whole file is written.

    channels: name -> (H, W) array, all of one shape; real numbers, stored as float32 (exactly, for float32 input),
        or as 16-bit half where the name is in half. Never half for Cryptomatte ranks or anything else that must
        keep its bits (IDs, depth).
    header: extra string attributes, e.g. cryptomatte.layer_header(...); the writer's own (compression, windows,
        channels, ...) cannot be overridden.
    half: names of channels to store as half floats."""
    file = _exr_file(channels, header, half)
    with atomic_path(Path(path)) as temporary:
        file.write(str(temporary))


def encode_multilayer_exr(
    channels: Mapping[str, np.ndarray], header: Mapping[str, str] | None = None, half: set[str] | None = None
) -> bytes:
    """The bytes write_multilayer_exr would write (for a process that hands the file to another to write)."""
    stream = io.BytesIO()
    _exr_file(channels, header, half).write(stream)
    return stream.getvalue()


def _exr_file(channels: Mapping[str, np.ndarray], header: Mapping[str, str] | None, half: set[str] | None):
    """channels, header and half as write_multilayer_exr takes them -> an OpenEXR.File, checked."""
    OpenEXR = openexr_module()
    if not channels:
        raise ValueError("an EXR file needs at least one channel")
    half = set(half or ())
    unknown = half - set(channels)
    if unknown:
        raise ValueError(f"half names channels that are not written: {', '.join(sorted(unknown))}")
    shape = None
    pixels: dict[str, np.ndarray] = {}
    for name, values in channels.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"EXR channel name {name!r}: a non-empty string is needed")
        array = np.asarray(values)
        if array.ndim != 2 or 0 in array.shape:
            raise ValueError(f"EXR channel {name!r}: expected a non-empty (H, W) array, got shape {array.shape}")
        if shape is None:
            shape = array.shape
        elif array.shape != shape:
            raise ValueError(f"EXR channel {name!r} is {array.shape}, the others {shape}: one size for all")
        if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
            raise TypeError(f"EXR channel {name!r}: real numbers are needed, got {array.dtype}")
        stored = np.float16 if name in half else np.float32
        pixels[name] = np.ascontiguousarray(array, dtype=stored)
    attributes: dict[str, object] = {}
    for key, value in (header or {}).items():
        if key in RESERVED_ATTRIBUTES:
            raise ValueError(f"EXR header attribute {key!r} is set by the writer")
        if not isinstance(key, str) or not isinstance(value, str):
            raise TypeError(f"EXR header attribute {key!r}: string names and string values only")
        attributes[key] = value
    attributes["compression"] = OpenEXR.ZIP_COMPRESSION
    attributes["type"] = OpenEXR.scanlineimage
    return OpenEXR.File(attributes, pixels)


def read_exr_channels(path: Path) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    """An OpenEXR file -> (its channels by full name, each (H, W) as stored: float32, float16 or uint32; its header
    attributes, including the format's own such as "compression" and "channels"). A multi-part file (Blender 5
    writes a part per pass, each channel under its full name) gives every part's channels, and the attributes of
    the first part that has each."""
    OpenEXR = openexr_module()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no EXR file at {path}")
    channels: dict[str, np.ndarray] = {}
    header: dict[str, object] = {}
    for part in OpenEXR.File(str(path), separate_channels=True).parts:
        channels.update((name, np.asarray(channel.pixels)) for name, channel in part.channels.items())
        for key, value in part.header.items():
            header.setdefault(key, value)
    return channels, header
