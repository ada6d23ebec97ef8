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


# Rows converted at a time to 8 bits: the float64 working copy stays a few MB however large the image.
CONVERT_PIXELS = 1 << 20


def to_8bit(image: np.ndarray, srgb: bool = False) -> np.ndarray:
    """(H, W, 3) linear floats -> uint8: clamp to [0, 1] as the seed's canvas does, optionally sRGB-encode, round."""
    height, width = image.shape[:2]
    out = np.empty(image.shape, dtype=np.uint8)
    step = max(1, CONVERT_PIXELS // max(1, width))
    for first in range(0, height, step):
        out[first : first + step] = _rows_to_8bit(image[first : first + step], srgb)
    return out


def _rows_to_8bit(image: np.ndarray, srgb: bool) -> np.ndarray:
    clamped = image.astype(np.float64)  # always a copy of its own, worked on in place
    np.nan_to_num(clamped, copy=False, nan=0.0)
    np.clip(clamped, 0.0, 1.0, out=clamped)
    if srgb:
        clamped = np.where(clamped <= 0.0031308, clamped * 12.92, 1.055 * np.power(clamped, 1.0 / 2.4) - 0.055)
    clamped *= 255.0
    clamped += 0.5
    return np.floor(clamped, out=clamped).astype(np.uint8)


# A temporary name is the target's, cut to this many bytes, plus a dot, 8 random characters and ".partial": within
# the 255 bytes a file name may have, however long the target's own name is.
TEMPORARY_NAME_BYTES = 200


@contextlib.contextmanager
def atomic_path(target: Path) -> Iterator[Path]:
    """A temporary path beside target that replaces it only when the block finishes without an exception.

    A target that is a symbolic link is followed, as a shell's `>` does: the file it points to is replaced and the
    link stays."""
    if target.is_symlink():
        target = Path(os.path.realpath(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    stem = target.name.encode()[:TEMPORARY_NAME_BYTES].decode(errors="ignore")
    handle, name = tempfile.mkstemp(prefix=f".{stem}.", suffix=".partial", dir=target.parent)
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


def encode_png(
    image: np.ndarray,
    srgb: bool = False,
    compress_level: int = 6,
    alpha: np.ndarray | None = None,
    converted: np.ndarray | None = None,
) -> bytes:
    """compress_level: zlib's, 0-9; 6 is Pillow's default, 3 about half the time for files about 40% larger.
    alpha (H, W): an RGBA PNG, the colours as they are (premultiplied, as rendered), alpha never sRGB-encoded.
    converted: to_8bit(image, srgb) where the caller has it already (an animation's frame made of the last one's
    bytes and its re-traced pixels)."""
    from PIL import Image  # the CLI's need only; the tracer itself runs on NumPy alone

    buffer = io.BytesIO()
    pixels = to_8bit(image, srgb) if converted is None else converted
    if alpha is None:
        made = Image.fromarray(pixels, mode="RGB")
    else:
        made = Image.fromarray(np.concatenate((pixels, to_8bit(alpha[..., None])), axis=2), mode="RGBA")
    made.save(buffer, format="PNG", compress_level=compress_level)
    return buffer.getvalue()


def write_image(
    image: np.ndarray,
    target: str | Path,
    srgb: bool = False,
    compress_level: int = 6,
    alpha: np.ndarray | None = None,
    converted: np.ndarray | None = None,
) -> Path:
    """Write (H, W, 3) linear floats to target (.png or .npy) atomically; returns the path. alpha (H, W): an RGBA
    .png, or an H x W x 4 .npy. converted: the image's to_8bit() where the caller has it (encode_png)."""
    target = Path(target)
    suffix = target.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"output must end in .png or .npy, got {target.name!r}")
    payload = encode_png(image, srgb, compress_level, alpha, converted) if suffix == ".png" else None
    with atomic_path(target) as temporary:
        if payload is not None:
            temporary.write_bytes(payload)
        else:
            _write_npy(image if alpha is None else np.concatenate((image, alpha[..., None]), axis=2), temporary)
    return target


def _write_npy(image: np.ndarray, path: Path) -> None:
    """(H, W, 3) -> a float32 .npy, a few rows at a time: no float32 copy of the whole image, and a full disk
    raises OSError(ENOSPC) from the write rather than NumPy's 'N requested and M written'."""
    with path.open("wb") as stream:
        np.lib.format.write_array_header_1_0(
            stream, {"descr": np.dtype(np.float32).str, "fortran_order": False, "shape": image.shape}
        )
        step = max(1, CONVERT_PIXELS // max(1, image.shape[1]))
        for first in range(0, image.shape[0], step):
            stream.write(np.ascontiguousarray(image[first : first + step], dtype=np.float32).tobytes())
