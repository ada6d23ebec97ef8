"""Image files and colour spaces -> a texture's linear float pixels (H, W, 3), row 0 the image's top.

A material's texture (docs/scene-format.md) gives its pixels inline or by a file's path: a NumPy `.npy` file of
(H, W), (H, W, 1), (H, W, 3) or (H, W, 4) numbers (floats as they are, 8-bit integers divided by 255, 16-bit by
65535), or a PNG file (8 or 16 bits, grey, RGB, palette, with or without alpha; not interlaced), decoded here with
zlib alone (the tracer needs nothing beyond NumPy). Alpha is dropped (a colour input reads the colour). Then the
colour space: "sRGB" values are decoded to linear with the sRGB curve (as Blender's sRGB images are), "linear" ones
(Blender's Non-Color and Linear spaces) are kept.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

COLORSPACES = ("sRGB", "linear")
MAX_TEXTURE_PIXELS = 1 << 26  # 64 megapixels (an 8192 x 8192 image): 768 MB as float32 RGB
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class TextureFileError(ValueError):
    """An image file that cannot be read as a texture; the message says why (no path: the loader names the field)."""


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB curve decoded (IEC 61966-2-1), elementwise in float64: c / 12.92 up to 0.04045, else
    ((c + 0.055) / 1.055) ^ 2.4."""
    c = np.asarray(values, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((np.maximum(c, 0.04045) + 0.055) / 1.055) ** 2.4)


def rgb_pixels(values: np.ndarray) -> np.ndarray:
    """(H, W), (H, W, 1), (H, W, 3) or (H, W, 4) numbers -> (H, W, 3) float64: grey repeated, alpha dropped;
    unsigned 8- and 16-bit integers scaled to [0, 1]."""
    array = np.asarray(values)
    if array.dtype == np.uint8:
        array = array / 255.0
    elif array.dtype == np.uint16:
        array = array / 65535.0
    array = np.asarray(array, dtype=np.float64)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in (1, 3, 4) or array.shape[0] == 0 or array.shape[1] == 0:
        raise TextureFileError(f"must be an image of (height, width[, 1, 3 or 4]) numbers, got shape {array.shape}")
    if array.shape[2] == 1:
        array = np.repeat(array, 3, axis=2)
    return array[:, :, :3]


def linear_pixels(values: np.ndarray, colorspace: str) -> np.ndarray:
    """An image's RGB values in its colour space -> (H, W, 3) float32 linear RGB."""
    rgb = rgb_pixels(values)
    if colorspace == "sRGB":
        rgb = srgb_to_linear(rgb)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def read_image(path: Path) -> np.ndarray:
    """An image file (.npy or .png) -> its values (H, W[, C]) as stored (integers or floats), row 0 the top."""
    try:
        size = path.stat().st_size
    except OSError as error:
        raise TextureFileError(f"cannot be read ({error.strerror or error})") from None
    if not path.is_file():
        raise TextureFileError("is not a regular file")
    with path.open("rb") as stream:
        head = stream.read(8)
    if head == PNG_SIGNATURE:
        return _read_png(path.read_bytes())
    if head.startswith(b"\x93NUMPY"):
        try:
            array = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as error:
            raise TextureFileError(f"is not a readable .npy file ({error})") from None
        if array.dtype.kind not in "fiu":
            raise TextureFileError(f"must hold numbers, got dtype {array.dtype}")
        return array
    raise TextureFileError(f"must be a PNG or .npy image file ({size} bytes of something else)")


def _read_png(data: bytes) -> np.ndarray:
    """A PNG file's bytes -> (H, W, C) uint8 or uint16 (C: 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA)."""
    position, chunks, header, palette = 8, [], None, None
    while position + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[position : position + 8])
        body = data[position + 8 : position + 8 + length]
        position += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body[:13])
        elif kind == b"PLTE":
            palette = np.frombuffer(body, dtype=np.uint8).reshape(-1, 3)
        elif kind == b"IDAT":
            chunks.append(body)
        elif kind == b"IEND":
            break
    if header is None or not chunks:
        raise TextureFileError("is not a complete PNG file (no IHDR or IDAT chunk)")
    width, height, depth, kind, _, _, interlace = header
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(kind)
    if channels is None or depth not in (8, 16) or (kind == 3 and depth != 8) or interlace != 0:
        raise TextureFileError(
            f"must be a non-interlaced 8- or 16-bit PNG (grey, RGB, palette, with or without alpha), got bit depth "
            f"{depth}, colour type {kind}, interlace {interlace}"
        )
    if width * height > MAX_TEXTURE_PIXELS:
        raise TextureFileError(f"has {width} x {height} pixels, more than the {MAX_TEXTURE_PIXELS} a texture may have")
    try:
        raw = zlib.decompress(b"".join(chunks))
    except zlib.error as error:
        raise TextureFileError(f"holds damaged PNG data ({error})") from None
    step = channels * depth // 8  # bytes per pixel
    stride = width * step
    if len(raw) < height * (stride + 1):
        raise TextureFileError("holds fewer PNG rows than its header says")
    rows = np.frombuffer(raw, dtype=np.uint8)[: height * (stride + 1)].reshape(height, stride + 1)
    out = np.zeros((height, stride), dtype=np.uint8)
    previous = np.zeros(stride, dtype=np.uint8)
    for y in range(height):
        kind_of_filter, line = int(rows[y, 0]), rows[y, 1:]
        if kind_of_filter == 0:
            row = line.copy()
        elif kind_of_filter == 1:  # Sub: a running sum along each byte of a pixel, modulo 256
            row = np.cumsum(line.reshape(-1, step).astype(np.uint64), axis=0).astype(np.uint8).reshape(-1)
        elif kind_of_filter == 2:  # Up
            row = line + previous
        elif kind_of_filter in (3, 4):  # Average and Paeth: each byte needs its decoded left neighbour
            row = _unfilter_sequential(kind_of_filter, line.tobytes(), previous.tobytes(), step)
        else:
            raise TextureFileError(f"holds an unknown PNG filter {kind_of_filter} in row {y}")
        out[y] = row
        previous = row
    if depth == 16:
        values = out.reshape(height, width * channels, 2)
        image = (values[..., 0].astype(np.uint16) << 8 | values[..., 1]).reshape(height, width, channels)
    else:
        image = out.reshape(height, width, channels)
    if kind == 3:
        if palette is None:
            raise TextureFileError("is a palette PNG without a palette (PLTE)")
        image = palette.take(image[..., 0], axis=0, mode="clip")
    return image


def _unfilter_sequential(kind: int, line: bytes, above: bytes, step: int) -> np.ndarray:
    """PNG's Average (3) and Paeth (4) filters undone for one row, byte by byte."""
    row = bytearray(line)
    for i in range(len(row)):
        left = row[i - step] if i >= step else 0
        up = above[i]
        if kind == 3:
            row[i] = (row[i] + ((left + up) >> 1)) & 0xFF
            continue
        corner = above[i - step] if i >= step else 0
        p = left + up - corner
        pa, pb, pc = abs(p - left), abs(p - up), abs(p - corner)
        predictor = left if pa <= pb and pa <= pc else up if pb <= pc else corner
        row[i] = (row[i] + predictor) & 0xFF
    return np.frombuffer(bytes(row), dtype=np.uint8)
