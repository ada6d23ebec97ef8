"""Names and per-sample hits -> Cryptomatte: ID floats, the manifest, the EXR header attributes and rank channels.

Cryptomatte as the Psyop specification (v1.2, the Cryptomatte committee's) defines it, and as Blender's compositor
and Nuke's gizmo read it:

- a name's ID is MurmurHash3_x86_32 (seed 0) of its UTF-8 bytes, stored as the float32 with those bits, except that
  an exponent of 0 or 255 (denormal, zero, inf, NaN) is moved to 1 or 254 by flipping its lowest bit;
- the manifest maps each name to the 8 hex digits of that float's bits (JSON, in the EXR header);
- each Cryptomatte layer has header attributes `cryptomatte/<key>/name, hash, conversion, manifest`, where <key> is
  the first 7 hex digits of the MurmurHash3 of the layer's name;
- per pixel, the IDs the pixel's samples saw are ranked by coverage (their share of the pixel's samples), and rank
  2i, 2i+1 go into the RGBA layer `<layer name>NN` (NN = i as two digits) as r = ID, g = coverage of rank 2i,
  b = ID, a = coverage of rank 2i+1: the channels in lower case and levels ranks in (levels + 1) // 2 layers
  (at most 16 ranks), as Cycles writes them in every Blender from 3.4 to 5.0.

A reader gets an object's matte as the sum, over the ranks, of the coverage where the rank's ID equals the object's
name_hash float. Background (nothing hit) has no rank: where a pixel saw fewer IDs than ranks, ID and coverage are 0.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterable

import numpy as np

HASH_NAME = "MurmurHash3_32"
CONVERSION = "uint32_to_float32"

# Blender's three Cryptomatte passes (View Layer > Passes > Cryptomatte), the last part of their layer names.
KINDS = {"object": "CryptoObject", "material": "CryptoMaterial", "asset": "CryptoAsset"}

RANK_CHANNELS = ("r", "g", "b", "a")  # Cycles' (its passes' channel ids are "rgba")
LEVELS_MAX = 16  # Blender's most (View Layer > Passes > Cryptomatte > Levels)

_MASK = 0xFFFFFFFF
# Pixels ranked at a time: the (chunk, S) working arrays stay a few MB however large the image is.
_CHUNK_VALUES = 1 << 21


def _rotl(value: int, bits: int) -> int:
    return ((value << bits) | (value >> (32 - bits))) & _MASK


def murmurhash3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3_x86_32 (Austin Appleby's, as in SMHasher) of data -> the unsigned 32-bit hash."""
    c1, c2 = 0xCC9E2D51, 0x1B873593
    h = seed & _MASK
    whole = len(data) - len(data) % 4
    for (block,) in struct.iter_unpack("<I", data[:whole]):
        k = _rotl((block * c1) & _MASK, 15)
        h ^= (k * c2) & _MASK
        h = (_rotl(h, 13) * 5 + 0xE6546B64) & _MASK
    tail = data[whole:]
    if tail:
        k = int.from_bytes(tail, "little")
        k = _rotl((k * c1) & _MASK, 15)
        h ^= (k * c2) & _MASK
    h ^= len(data)
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & _MASK
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & _MASK
    return h ^ (h >> 16)


def float_bits(hash32: int) -> int:
    """A 32-bit hash -> the bits of its Cryptomatte float: the hash with an exponent of 0 or 255 moved to 1 or 254
    (its lowest exponent bit flipped, which is the specification's clamp to [1, 254]); never zero, denormal, inf
    or NaN."""
    exponent = (hash32 >> 23) & 0xFF
    return hash32 ^ (1 << 23) if exponent in (0, 255) else hash32


def _bits_to_float(bits: int) -> float:
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def name_hash(name: str) -> tuple[int, float]:
    """A name -> (its MurmurHash3_x86_32 of the UTF-8 bytes with seed 0, the float32 ID stored in the pixels).

    The float is returned as a Python float holding exactly that float32 value (np.float32(f) == f)."""
    hash32 = murmurhash3_32(name.encode("utf-8"))
    return hash32, _bits_to_float(float_bits(hash32))


def hex_id(name: str) -> str:
    """A name -> its manifest value: the 8 lowercase hex digits of its ID float's bits, as the specification writes
    them (equal to the raw hash's hex except where the exponent was moved, 2 names in 256)."""
    return f"{float_bits(name_hash(name)[0]):08x}"


def manifest(names: Iterable[str]) -> str:
    """Names -> the manifest JSON `{"name":"hex",...}`: each distinct name once, in the order first given.

    Non-ASCII names are written as UTF-8, not as \\u escapes: Blender's manifest parser does not decode escapes."""
    table = {name: hex_id(name) for name in dict.fromkeys(names)}
    return json.dumps(table, ensure_ascii=False, separators=(",", ":"))


def layer_key(layer_name: str) -> str:
    """A Cryptomatte layer's name -> its 7-hex-digit metadata key: the first 7 hex digits of the MurmurHash3 of the
    name, as Blender makes it (the specification's suggestion)."""
    return f"{murmurhash3_32(layer_name.encode('utf-8')):08x}"[:7]


def layer_header(layer_name: str, names: Iterable[str], kind: str = "object") -> dict[str, str]:
    """The EXR header attributes of one Cryptomatte layer: `cryptomatte/<key>/name`, `/hash`, `/conversion` and
    `/manifest` (str each), to merge into the file's header.

    layer_name is the channels' prefix before the rank number, e.g. "ViewLayer.CryptoObject" for channels
    "ViewLayer.CryptoObject00.R", ... (channel_names); names are the names whose IDs the layer's pixels may hold.
    kind is which of Blender's Cryptomatte passes the layer is ("object", "material" or "asset"): a layer named
    after another of them (…CryptoMaterial with kind "object") is refused as a likely mix-up."""
    if not layer_name:
        raise ValueError("a Cryptomatte layer needs a name")
    if kind not in KINDS:
        raise ValueError(f"Cryptomatte kind {kind!r}: expected one of {', '.join(KINDS)}")
    last = layer_name.rsplit(".", 1)[-1]
    if last in KINDS.values() and last != KINDS[kind]:
        raise ValueError(f"Cryptomatte layer {layer_name!r} is named as Blender's {last}, not as the {kind} kind")
    prefix = f"cryptomatte/{layer_key(layer_name)}/"
    return {
        prefix + "name": layer_name,
        prefix + "hash": HASH_NAME,
        prefix + "conversion": CONVERSION,
        prefix + "manifest": manifest(names),
    }


def renamed(render, kind: str) -> dict[str, str]:
    """The names Cryptomatte gives a scene's objects (kind "object") or materials ("material") where they are not
    their own (RenderSettings.cryptomatte_names: a Blender export's, the Blender names Cycles writes)."""
    return {name: matte for of, name, matte in getattr(render, "cryptomatte_names", ()) if of == kind}


def matte_names(names: Iterable[str], render, kind: str) -> list[str]:
    """Scene names -> the names Cryptomatte hashes and lists for them (renamed), in the same order."""
    table = renamed(render, kind)
    return [table.get(name, name) for name in names]


def rank_layers(levels: int) -> int:
    """Ranks -> the RGBA layers that hold them: 2 ranks each, rounded up, at most LEVELS_MAX ranks, as Cycles does
    (`(min(16, levels) + 1) // 2`: levels 2 -> 1 layer, 6 -> 3, 10 -> 5)."""
    if levels < 1:
        raise ValueError(f"Cryptomatte levels {levels}: at least 1 rank is needed")
    return (min(LEVELS_MAX, levels) + 1) // 2


def channel_names(layer_name: str, levels: int = 6) -> list[str]:
    """The channel names of a layer's ranks, in the column order of ranks(): `<layer_name>00.r`, `.g`, `.b`, `.a`,
    `<layer_name>01.r`, ... for rank_layers(levels) RGBA layers (an odd levels gets one more rank, as in Cycles)."""
    return [f"{layer_name}{layer:02d}.{channel}" for layer in range(rank_layers(levels)) for channel in RANK_CHANNELS]


def ranks(sample_ids: np.ndarray, hashes: np.ndarray, levels: int = 6) -> np.ndarray:
    """What each pixel's samples saw -> its ranked (ID float, coverage) pairs, the Cryptomatte rank channels.

    sample_ids: (P, S) integers, per pixel and sample the index into hashes of what the sample saw first; -1 for
        nothing (background), which gets no rank.
    hashes: (K,) float32 ID floats (name_hash's floats), one per index.
    levels: how many ranks to keep; rounded up to whole RGBA layers (rank_layers).
    Returns (P, 4 * rank_layers(levels)) float32: columns (ID, coverage) of rank 0, rank 1, ... in the order of
    channel_names. Coverage is the share of the pixel's S samples (background included, so a pixel's coverages
    add up to its share of non-background samples); ranks run by coverage descending, equal coverages by index
    into hashes ascending; where a pixel saw fewer distinct IDs than ranks, the rest are 0 (ID and coverage)."""
    sample_ids = np.asarray(sample_ids)
    hashes = np.asarray(hashes)
    if sample_ids.ndim != 2 or not np.issubdtype(sample_ids.dtype, np.integer):
        raise ValueError(f"sample_ids must be (P, S) integers, got {sample_ids.dtype} {sample_ids.shape}")
    if hashes.ndim != 1:
        raise ValueError(f"hashes must be (K,), got {hashes.shape}")
    pixels, samples = sample_ids.shape
    if samples < 1:
        raise ValueError("sample_ids needs at least one sample per pixel")
    if sample_ids.size and (sample_ids.min() < -1 or sample_ids.max() >= hashes.size):
        raise ValueError(f"sample_ids must lie in [-1, {hashes.size}) (indices into hashes, -1 for background)")
    count = 2 * rank_layers(levels)
    # One more entry, 0.0, for "no rank": where a rank is empty its ID reads from there.
    table = np.append(hashes.astype(np.float32), np.float32(0.0))
    out = np.zeros((pixels, 2 * count), dtype=np.float32)
    step = max(1, _CHUNK_VALUES // samples)
    for first in range(0, pixels, step):
        _rank_rows(sample_ids[first : first + step], table, count, out[first : first + step])
    return out


def _rank_rows(sample_ids: np.ndarray, table: np.ndarray, count: int, out: np.ndarray) -> None:
    """ranks() for a chunk of rows, written into out (rows, 2 * count; zeros). A pixel whose samples saw one ID (or
    nothing) has that one rank, its share of the samples, without ranking (every pixel at 1 sample, and at more
    every pixel inside an object's silhouette); the others are ranked (_rank_mixed)."""
    samples = sample_ids.shape[1]
    # each row's largest ID, its smallest ID that is not background (the largest where it saw nothing) and how many
    # samples saw something: column by column (a reduction over a few columns is slow in NumPy)
    columns = [sample_ids[:, sample] for sample in range(samples)]
    top = columns[0].copy()
    for column in columns[1:]:
        np.maximum(top, column, out=top)
    low = top.copy()
    hits = np.zeros(len(top), dtype=np.int64)
    for column in columns:
        seen = column >= 0
        np.minimum(low, np.where(seen, column, top), out=low)
        hits += seen
    one = np.flatnonzero(low == top)
    seen = top.take(one)
    out[one, 0] = table.take(np.where(seen >= 0, seen, table.size - 1))
    out[one, 1] = hits.take(one).astype(np.float32) / np.float32(samples)
    mixed = np.flatnonzero(low != top)
    if mixed.size:
        ranked = np.zeros((mixed.size, out.shape[1]), dtype=np.float32)
        _rank_mixed(sample_ids.take(mixed, axis=0), table, count, ranked)
        out[mixed] = ranked


def _rank_mixed(sample_ids: np.ndarray, table: np.ndarray, count: int, out: np.ndarray) -> None:
    """The ranking of rows whose samples saw several IDs, written into out (rows, 2 * count)."""
    rows, samples = sample_ids.shape
    ids = np.sort(sample_ids.astype(np.int64), axis=1)  # equal IDs side by side, ascending
    position = np.arange(samples, dtype=np.int32)
    starts = np.ones(ids.shape, dtype=bool)
    np.not_equal(ids[:, 1:], ids[:, :-1], out=starts[:, 1:])
    ends = np.ones(ids.shape, dtype=bool)
    ends[:, :-1] = starts[:, 1:]
    run_start = np.maximum.accumulate(np.where(starts, position, 0), axis=1)
    # Each run of one ID scores its length at its last sample; everything else (and background) scores 0.
    score = np.where(ends & (ids >= 0), position - run_start + 1, 0).astype(np.int32)
    row = np.arange(rows)
    for rank in range(count):
        best = score.argmax(axis=1)  # the first maximum: the lowest ID among equal coverages
        hits = score[row, best]
        found = hits > 0
        index = np.where(found, ids[row, best], table.size - 1)
        out[:, 2 * rank] = table[index]
        out[:, 2 * rank + 1] = hits.astype(np.float32) / np.float32(samples)
        score[row, best] = 0
        if not found.any():
            break
