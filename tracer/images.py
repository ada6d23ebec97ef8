"""Linear float images -> files: .npy (float32 linear) or 8-bit .png (the documented clamp, or sRGB), atomically.

Every file is written beside its target under a temporary name and renamed into place, so an error or Ctrl-C
never leaves a partial image where the user expects one.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

SUFFIXES = (".png", ".npy")


def to_8bit(image: np.ndarray, srgb: bool = False) -> np.ndarray:
    """(H, W, 3) linear floats -> uint8: clamp to [0, 1] as the seed's canvas does, optionally sRGB-encode, round."""
    clamped = image.astype(np.float64)  # always a copy of its own, worked on in place (an animation's every frame)
    np.nan_to_num(clamped, copy=False, nan=0.0)
    np.clip(clamped, 0.0, 1.0, out=clamped)
    if srgb:
        clamped = np.where(clamped <= 0.0031308, clamped * 12.92, 1.055 * np.power(clamped, 1.0 / 2.4) - 0.055)
    clamped *= 255.0
    clamped += 0.5
    return np.floor(clamped, out=clamped).astype(np.uint8)


@contextlib.contextmanager
def atomic_path(target: Path) -> Iterator[Path]:
    """A temporary path beside target that replaces it only when the block finishes without an exception."""
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".partial", dir=target.parent)
    os.close(handle)
    temporary = Path(name)
    umask = os.umask(0)
    os.umask(umask)
    temporary.chmod(0o666 & ~umask)  # mkstemp makes 0600; the finished file gets the usual permissions
    try:
        yield temporary
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def encode_png(image: np.ndarray, srgb: bool = False, compress_level: int = 6) -> bytes:
    """compress_level: zlib's, 0-9; 6 is Pillow's default, 3 about half the time for files about 40% larger."""
    from PIL import Image  # the CLI's need only; the tracer itself runs on NumPy alone

    buffer = io.BytesIO()
    Image.fromarray(to_8bit(image, srgb), mode="RGB").save(buffer, format="PNG", compress_level=compress_level)
    return buffer.getvalue()


def write_image(image: np.ndarray, target: str | Path, srgb: bool = False, compress_level: int = 6) -> Path:
    """Write (H, W, 3) linear floats to target (.png or .npy) atomically; returns the path."""
    target = Path(target)
    suffix = target.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"output must end in .png or .npy, got {target.name!r}")
    payload = encode_png(image, srgb, compress_level) if suffix == ".png" else None
    with atomic_path(target) as temporary:
        if payload is not None:
            temporary.write_bytes(payload)
        else:
            with temporary.open("wb") as stream:
                np.save(stream, image.astype(np.float32))
    return target
