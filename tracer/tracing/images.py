"""Linear float images -> files: .npy (float32 linear) or 8-bit .png (the documented clamp, or sRGB), atomically.

Every file is written beside its target under a temporary name and renamed into place, so an error or Ctrl-C
never leaves a partial image where the user expects one; what a killed writer left is swept by the next command
that writes into the folder.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import struct
import tempfile
import time
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None

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


# A temporary name is the target's, cut to this many bytes, then the writer's mark (its process id and 8 random
# characters) and ".partial": within the 255 bytes a file name may have, however long the target's own name is.
TEMPORARY_NAME_BYTES = 200
TEMPORARY_MARK = "weathervane"
TEMPORARY_NAME = re.compile(rf"^\..*\.{TEMPORARY_MARK}-(?P<pid>\d+)-[a-z0-9_]{{8}}\.partial$")
# A temporary file whose lock is free is a killed writer's, except in the instant between its creation and the
# lock; its process id tells those apart, and a file older than this is stale whatever runs under that id now.
STALE_AFTER_SECONDS = 60.0


@contextlib.contextmanager
def atomic_path(target: Path) -> Iterator[Path]:
    """A temporary path beside target that replaces it only when the block finishes without an exception.

    The writer holds an advisory lock on the temporary file while the block runs, so that sweep_stale_temporaries
    in any process tells a live writer's file from one a killed writer left. A target that is a symbolic link is
    followed, as a shell's `>` does: the file it points to is replaced and the link stays."""
    if target.is_symlink():
        target = Path(os.path.realpath(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    stem = target.name.encode()[:TEMPORARY_NAME_BYTES].decode(errors="ignore")
    handle, name = tempfile.mkstemp(
        prefix=f".{stem}.{TEMPORARY_MARK}-{os.getpid()}-", suffix=".partial", dir=target.parent
    )
    temporary = Path(name)
    try:
        _lock(handle, wait=True)
        umask = os.umask(0)
        os.umask(umask)
        temporary.chmod(0o666 & ~umask)  # mkstemp makes 0600; the finished file gets the usual permissions
        yield temporary
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    finally:
        os.close(handle)  # releases the lock


def _lock(handle: int, wait: bool) -> bool:
    """Takes an exclusive advisory lock on the open file; False where another open file holds one (wait=False).
    Where the system has no flock (Windows), every lock is taken."""
    if fcntl is None:
        return True
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except BlockingIOError:
        return False
    return True


def sweep_stale_temporaries(folder: Path) -> int:
    """Removes the temporary files atomic_path left in folder when their writer was killed (kill -9, a power cut);
    returns how many. A live writer's file (in this or any process) is never touched: it holds its lock. Without
    flock (Windows) nothing is removed."""
    if fcntl is None:
        return 0
    try:
        names = [entry.name for entry in os.scandir(folder) if TEMPORARY_NAME.match(entry.name)]
    except OSError:  # no folder yet, or not readable: nothing of ours to sweep
        return 0
    removed = 0
    for name in names:
        path = Path(folder) / name
        try:
            handle = os.open(path, os.O_RDONLY)
        except OSError:  # renamed into place or swept meanwhile
            continue
        try:
            if not _lock(handle, wait=False):
                continue
            writer = int(TEMPORARY_NAME.match(name)["pid"])
            if _process_alive(writer) and time.time() - os.fstat(handle).st_mtime < STALE_AFTER_SECONDS:
                continue  # created an instant ago, before its writer took the lock
            path.unlink(missing_ok=True)
            removed += 1
        except OSError:
            continue
        finally:
            os.close(handle)
    return removed


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


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


# An animation's frames are PNG files written here (not by Pillow): every row Sub-filtered (each byte minus the one a
# pixel to its left, so a row's filtered bytes depend on that row alone) and deflated PNG_ROWS rows at a time, each
# piece ending on a flush (no back-references into the rows before it), with zlib's run-length strategy. A piece's
# bytes then depend on its own rows only, so a frame that shares most rows with the last one compresses only the
# pieces that changed and reuses the others' bytes: the same file as compressing every piece. A 640x480 frame of
# the default animation, one thread: Pillow's adaptive filters and zlib level 3 (before) 17.5 ms and 38 KB, level 6
# 27 ms and 27 KB; this 3.9 ms and 33 KB for a whole frame, 2.5 ms where only the changed pieces are compressed.
PNG_ROWS = 16
PNG_LEVEL = 1  # with the run-length strategy the level changes little (level 6: 3.8 ms, the same 33 KB)


class FramePng:
    """8-bit frames -> PNG bytes (PNG_ROWS above), keeping the last frame's filtered rows and compressed pieces so
    that the next frame compresses only the pieces whose rows changed. One instance per sequence of frames, used by
    one thread at a time."""

    def __init__(self) -> None:
        self._rows: np.ndarray | None = None  # (H, 1 + W * C) the last frame's filtered rows
        self._pieces: list[bytes] = []

    def encode(self, pixels: np.ndarray) -> bytes:
        """(H, W, 3) or (H, W, 4) uint8 -> an RGB or RGBA PNG file's bytes."""
        height, width, channels = pixels.shape
        flat = pixels.reshape(height, width * channels)
        rows = np.empty((height, 1 + width * channels), dtype=np.uint8)
        rows[:, 0] = 1  # filter type Sub
        rows[:, 1 : 1 + channels] = flat[:, :channels]
        np.subtract(flat[:, channels:], flat[:, :-channels], out=rows[:, 1 + channels :])  # modulo 256
        last = self._rows
        if last is None or last.shape != rows.shape:
            changed = np.ones(-(-height // PNG_ROWS), dtype=bool)
            self._pieces = [b""] * changed.size
        else:
            changed_rows = (rows != last).any(axis=1)
            changed = np.logical_or.reduceat(changed_rows, np.arange(0, height, PNG_ROWS))
        for piece in np.flatnonzero(changed).tolist():
            start = piece * PNG_ROWS
            deflate = zlib.compressobj(PNG_LEVEL, zlib.DEFLATED, -15, 9, zlib.Z_RLE)  # raw deflate: no header
            data = rows[start : start + PNG_ROWS].tobytes()
            self._pieces[piece] = deflate.compress(data) + deflate.flush(zlib.Z_FULL_FLUSH)
        self._rows = rows
        end = zlib.compressobj(PNG_LEVEL, zlib.DEFLATED, -15).flush()  # the final (empty) block
        # zlib's header (deflate, 32K window, fastest; (0x78 * 256 + 0x01) % 31 == 0) and its Adler-32 at the end
        stream = b"".join((b"\x78\x01", *self._pieces, end, struct.pack(">I", zlib.adler32(rows))))
        header = struct.pack(">IIBBBBB", width, height, 8, 6 if channels == 4 else 2, 0, 0, 0)
        return b"".join((b"\x89PNG\r\n\x1a\n", _chunk(b"IHDR", header), _chunk(b"IDAT", stream), _chunk(b"IEND", b"")))


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)))


def encode_frame(
    image: np.ndarray,
    srgb: bool = False,
    alpha: np.ndarray | None = None,
    converted: np.ndarray | None = None,
    frames: FramePng | None = None,
) -> bytes:
    """An animation frame's PNG bytes (FramePng): alpha and converted as encode_png's; frames: the sequence's encoder
    (its last frame's pieces reused), or None for a frame of its own. The same bytes either way."""
    pixels = to_8bit(image, srgb) if converted is None else converted
    if alpha is not None:
        pixels = np.concatenate((pixels, to_8bit(alpha[..., None])), axis=2)
    return (frames or FramePng()).encode(pixels)


def write_frame(target: str | Path, payload: bytes) -> Path:
    """Write an encoded frame (encode_frame) to target atomically; returns the path."""
    target = Path(target)
    with atomic_path(target) as temporary:
        temporary.write_bytes(payload)
    return target


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
