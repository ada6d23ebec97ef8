"""tracer/tracing/cryptomatte.py against published values (MurmurHash3 test vectors, the Cryptomatte specification's
manifest, Nuke's and Blender's own test values), a per-pixel reference ranking, and a reader written from the
specification that picks mattes out of a written EXR file."""

from __future__ import annotations

import json
import random
import shutil
import struct
import subprocess

import numpy as np
import pytest

from tracer.scene import passes as ps
from tracer.tracing import cryptomatte
from tracer.tracing.cryptomatte import (
    channel_names,
    hex_id,
    layer_header,
    layer_key,
    manifest,
    murmurhash3_32,
    name_hash,
    rank_layers,
    ranks,
)
from tracer.tracing.exr import read_exr_channels, write_multilayer_exr

SEED = 0x9747B28C

# MurmurHash3_x86_32 test vectors as SMHasher's reference implementation gives them: the table widely published for
# checking ports (Stack Overflow, "MurmurHash3 test vectors", Ian Boyd's answer), covering tails of 0 to 3 bytes and
# seeds 0, 1, 2^32-1; "foo" is the mmh3 package's README example (mmh3.hash("foo") == -156908512, i.e. 0xf6a5c420).
MURMUR_VECTORS = [
    (b"", 0, 0x00000000),
    (b"", 1, 0x514E28B7),
    (b"", 0xFFFFFFFF, 0x81F16F39),
    (b"\0\0\0\0", 0, 0x2362F9DE),
    (b"aaaa", SEED, 0x5A97808A),
    (b"aaa", SEED, 0x283E0130),
    (b"aa", SEED, 0x5D211726),
    (b"a", SEED, 0x7FA09EA6),
    (b"abcd", SEED, 0xF0478627),
    (b"abc", SEED, 0xC84A62DD),
    (b"ab", SEED, 0x74875592),
    (b"Hello, world!", SEED, 0x24884CBA),
    ("ππππππππ".encode(), SEED, 0xD58063C1),
    (b"The quick brown fox jumps over the lazy dog", SEED, 0x2FA826CD),
    (b"foo", 0, 0xF6A5C420),
]

# Nuke's gizmo tests (Psyop/Cryptomatte, nuke/cryptomatte_utilities_tests.py, class CryptoHashing): mm3hash_float of
# names, the last two the UTF-8 of Bulgarian "равнина" and German "mädchen"; compared there at single precision.
NUKE_FLOATS = {
    "hello": 6.0705627102400005616e-17,
    "cube": -4.08461912519e15,
    "sphere": 2.79018604383e15,
    "plane": 3.66557617593e-11,
    "равнина": -1.3192631212399999468e-25,
    "mädchen": 6.2361298211599995797e25,
}

# The specification's manifest example (Psyop/Cryptomatte, specification/cryptomatte_specification.rtf, v1.1.5,
# "Metadata": exr/cryptomatte/.../manifest = {"bunny":"13851a76", "default":"42c9679f"} and
# {"bunny_porcelain_mat":"b24b26d4"}).
SPEC_MANIFEST = {"bunny": "13851a76", "default": "42c9679f", "bunny_porcelain_mat": "b24b26d4"}

# Blender's metadata keys (blender/blender, source/blender/blenkernel/intern/cryptomatte_test.cc: meta_data_key and
# session_from_stamp_data): the first 7 hex digits of the MurmurHash3 of the layer name.
BLENDER_KEYS = {
    "ViewLayer.CryptoMaterial": "c7dbf5e",
    "𝖚𝖓𝖎𝖈𝖔𝖉𝖊.CryptoMaterial": "b990b65",
    "viewlayername.layer1": "87f095e",
    "viewlayername.layer2": "c42daa7",
}


def bits_of(value: float) -> int:
    return struct.unpack("<I", struct.pack("<f", value))[0]


def float_of(bits: int) -> float:
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def names_with_exponent(exponents: set[int], wanted: int) -> list[str]:
    """The first names "object.N" whose raw hash has one of these exponents (about 1 in 256 for 0 or 255)."""
    found = []
    number = 0
    while len(found) < wanted:
        name = f"object.{number}"
        if (murmurhash3_32(name.encode()) >> 23) & 0xFF in exponents:
            found.append(name)
        number += 1
    return found


@pytest.mark.parametrize(("data", "seed", "expected"), MURMUR_VECTORS)
def test_murmurhash3_matches_the_published_vectors(data: bytes, seed: int, expected: int) -> None:
    assert murmurhash3_32(data, seed) == expected


@pytest.mark.parametrize(("name", "value"), NUKE_FLOATS.items())
def test_id_floats_match_nukes_test_values(name: str, value: float) -> None:
    assert name_hash(name)[1] == float(np.float32(value))


@pytest.mark.parametrize(("name", "hexadecimal"), SPEC_MANIFEST.items())
def test_manifest_values_match_the_specifications_example(name: str, hexadecimal: str) -> None:
    assert hex_id(name) == hexadecimal
    assert f"{name_hash(name)[0]:08x}" == hexadecimal
    assert json.loads(manifest([name])) == {name: hexadecimal}


@pytest.mark.parametrize(("layer", "key"), BLENDER_KEYS.items())
def test_layer_keys_match_blenders(layer: str, key: str) -> None:
    assert layer_key(layer) == key
    kind = "material" if layer.endswith("CryptoMaterial") else "object"
    assert f"cryptomatte/{key}/name" in layer_header(layer, [], kind=kind)


def test_id_floats_are_always_normal_finite_float32() -> None:
    generator = random.Random(7)
    alphabet = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-/:äπ日"
    names = ["".join(generator.choices(alphabet, k=generator.randint(0, 24))) for _ in range(20000)]
    names += names_with_exponent({0, 255}, 20)
    values = np.array([name_hash(name)[1] for name in names], dtype=np.float64)
    assert np.array_equal(values.astype(np.float32).astype(np.float64), values)  # each is exactly a float32
    assert np.isfinite(values).all()
    assert (np.abs(values) >= np.finfo(np.float32).tiny).all()  # neither zero nor denormal


@pytest.mark.parametrize("exponent", [0, 255])
def test_the_exponent_fix_flips_only_the_lowest_exponent_bit(exponent: int) -> None:
    for name in names_with_exponent({exponent}, 5):
        raw, value = name_hash(name)
        bits = bits_of(value)
        assert bits == raw ^ (1 << 23)
        assert (bits >> 23) & 0xFF == (1 if exponent == 0 else 254)  # the specification's clamp to [1, 254]
        assert bits >> 31 == raw >> 31  # the sign stays


def test_a_manifest_decodes_to_the_pixels_ids_the_way_nuke_and_blender_read_it() -> None:
    names = ["Cube", "Sphere", "Plane.001", 'a "quoted" name', "ünïcödé", *names_with_exponent({0, 255}, 6)]
    table = json.loads(manifest([*names, "Cube"]))
    assert list(table) == names  # each name once, in the order given
    for name, hexadecimal in table.items():
        assert len(hexadecimal) == 8 and hexadecimal == hexadecimal.lower()
        value = name_hash(name)[1]
        assert float_of(int(hexadecimal, 16)) == value  # Nuke: the hex digits are the float's bits
        assert float_of(cryptomatte.float_bits(int(hexadecimal, 16))) == value  # Blender: a hash, then converted
    assert "ünïcödé" in manifest(["ünïcödé"])  # UTF-8 itself: Blender's parser reads no \u escapes


def test_layer_header_holds_the_four_attributes() -> None:
    header = layer_header("ViewLayer.CryptoObject", ["Cube", "Sphere"])
    key = layer_key("ViewLayer.CryptoObject")
    assert header == {
        f"cryptomatte/{key}/name": "ViewLayer.CryptoObject",
        f"cryptomatte/{key}/hash": "MurmurHash3_32",
        f"cryptomatte/{key}/conversion": "uint32_to_float32",
        f"cryptomatte/{key}/manifest": manifest(["Cube", "Sphere"]),
    }
    assert len(f"cryptomatte/{key}/conversion") <= 31  # the attribute-name limit the 7-digit key is for
    assert layer_header("ViewLayer.CryptoMaterial", ["Steel"], kind="material")
    with pytest.raises(ValueError, match="CryptoMaterial"):
        layer_header("ViewLayer.CryptoMaterial", ["Steel"], kind="object")
    with pytest.raises(ValueError, match="kind"):
        layer_header("ViewLayer.CryptoObject", [], kind="mesh")


def test_channel_names_are_rgba_layers_of_two_ranks_in_lower_case_as_cycles_writes_them() -> None:
    assert channel_names("CryptoObject", 4) == [
        "CryptoObject00.r",
        "CryptoObject00.g",
        "CryptoObject00.b",
        "CryptoObject00.a",
        "CryptoObject01.r",
        "CryptoObject01.g",
        "CryptoObject01.b",
        "CryptoObject01.a",
    ]
    assert channel_names("ViewLayer.CryptoMaterial", 3) == channel_names("ViewLayer.CryptoMaterial", 4)
    assert len(channel_names("X", 6)) == 12
    with pytest.raises(ValueError):
        channel_names("X", 0)


@pytest.mark.parametrize(("levels", "layers"), [(1, 1), (2, 1), (6, 3), (7, 4), (10, 5), (16, 8), (20, 8)])
def test_levels_give_cycles_layers_at_most_sixteen_ranks(levels: int, layers: int) -> None:
    """Cycles' `(min(16, levels) + 1) // 2` RGBA layers (intern/cycles/blender/addon/engine.py, 3.4 to 5.0)."""
    assert rank_layers(levels) == layers == ps.cryptomatte_layers(levels)
    assert channel_names("L", levels)[-1] == f"L{layers - 1:02d}.a"
    assert ps.width("cryptomatte_object", levels) == 4 * layers


def reference_ranks(sample_ids: np.ndarray, hashes: np.ndarray, levels: int) -> np.ndarray:
    """The ranking filter pixel by pixel, as the specification describes it: count each ID's samples, divide by the
    pixel's samples, sort by coverage descending (equal coverages by index ascending), keep the first ranks."""
    count = 2 * ((levels + 1) // 2)
    out = np.zeros((sample_ids.shape[0], 2 * count), dtype=np.float32)
    for pixel, row in enumerate(sample_ids.tolist()):
        seen: dict[int, int] = {}
        for index in row:
            if index >= 0:
                seen[index] = seen.get(index, 0) + 1
        ordered = sorted(seen.items(), key=lambda item: (-item[1], item[0]))[:count]
        for rank, (index, hits) in enumerate(ordered):
            out[pixel, 2 * rank] = hashes[index]
            out[pixel, 2 * rank + 1] = np.float32(hits / len(row))
    return out


@pytest.mark.parametrize("samples", [1, 4, 16])
@pytest.mark.parametrize("levels", [1, 2, 3, 6])
def test_ranks_match_a_per_pixel_reference(samples: int, levels: int) -> None:
    generator = np.random.default_rng(samples * 100 + levels)
    names = [f"object{index}" for index in range(9)]
    hashes = np.array([name_hash(name)[1] for name in names], dtype=np.float32)
    # Few IDs per pixel (so coverages tie often) and background in about a quarter of the samples.
    sample_ids = generator.integers(-1, 4, size=(500, samples)) + generator.integers(0, 6, size=(500, 1))
    sample_ids[sample_ids < generator.integers(0, 6, size=(500, 1))] = -1
    result = ranks(sample_ids, hashes, levels)
    assert result.dtype == np.float32
    assert result.shape == (500, len(channel_names("L", levels)))
    assert np.array_equal(result, reference_ranks(sample_ids, hashes, levels))


@pytest.mark.parametrize("samples", [2, 9])
def test_pixels_whose_samples_saw_one_id_and_pixels_that_saw_several_are_ranked_alike(samples: int) -> None:
    """As inside and on the edges of objects: most pixels' samples saw one ID (or that ID and background), some saw
    several; both kinds, interleaved and chunked, match the per-pixel reference."""
    generator = np.random.default_rng(samples)
    hashes = np.array([name_hash(f"part{index}")[1] for index in range(6)], dtype=np.float32)
    sample_ids = np.repeat(generator.integers(-1, 6, size=(800, 1)), samples, axis=1)
    sample_ids[generator.random((800, samples)) < 0.2] = -1  # background in some samples of one-ID pixels
    edges = generator.random(800) < 0.3
    sample_ids[edges] = generator.integers(-1, 6, size=(int(edges.sum()), samples))
    expected = reference_ranks(sample_ids, hashes, 4)
    assert np.array_equal(ranks(sample_ids, hashes, 4), expected)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cryptomatte, "_CHUNK_VALUES", 13 * samples)
        assert np.array_equal(ranks(sample_ids, hashes, 4), expected)


def test_coverages_add_up_to_the_share_of_samples_that_hit_something() -> None:
    generator = np.random.default_rng(3)
    hashes = np.array([name_hash(f"n{index}")[1] for index in range(5)], dtype=np.float32)
    sample_ids = generator.integers(-1, 5, size=(500, 16))
    result = ranks(sample_ids, hashes, levels=6)  # 6 ranks hold all 5 IDs
    share = (sample_ids >= 0).sum(axis=1) / 16
    np.testing.assert_allclose(result[:, 1::2].sum(axis=1), share, rtol=0, atol=1e-6)
    coverage = result[:, 1::2]
    assert (np.diff(coverage, axis=1) <= 0).all()  # descending
    assert (result[:, 0::2][coverage == 0] == 0).all()  # an empty rank's ID is 0
    fewer = ranks(sample_ids, hashes, levels=2)
    assert (fewer[:, 1::2].sum(axis=1) <= share + 1e-6).all()


def test_ranks_are_the_same_however_the_pixels_are_chunked(monkeypatch: pytest.MonkeyPatch) -> None:
    generator = np.random.default_rng(11)
    hashes = np.array([name_hash(f"n{index}")[1] for index in range(7)], dtype=np.float32)
    sample_ids = generator.integers(-1, 7, size=(1001, 4)).astype(np.int32)
    whole = ranks(sample_ids, hashes, 4)
    monkeypatch.setattr(cryptomatte, "_CHUNK_VALUES", 4 * 37)
    assert np.array_equal(ranks(sample_ids, hashes, 4), whole)


def test_ranks_refuse_indices_outside_the_hashes() -> None:
    hashes = np.array([1.0, 2.0], dtype=np.float32)
    with pytest.raises(ValueError, match="sample_ids"):
        ranks(np.array([[0, 2]]), hashes)
    with pytest.raises(ValueError, match="sample_ids"):
        ranks(np.array([[-2, 0]]), hashes)
    with pytest.raises(ValueError, match="sample_ids"):
        ranks(np.array([0.0, 1.0]), hashes)
    assert not ranks(np.full((3, 2), -1), np.zeros(0, dtype=np.float32)).any()  # all background, no names


def read_mattes(path, layer_name: str, names: list[str]) -> dict[str, np.ndarray]:
    """A reader written from the specification: find the layer by its `name` attribute, the names' IDs in its
    manifest (hex digits of the float's bits), the rank channels `<name>NN.RGBA`; a matte is the sum of the
    coverages of the ranks whose ID is the name's."""
    channels, header = read_exr_channels(path)
    (prefix,) = [key[: -len("name")] for key, value in header.items() if key.endswith("/name") and value == layer_name]
    assert header[prefix + "hash"] == "MurmurHash3_32" and header[prefix + "conversion"] == "uint32_to_float32"
    ids = {
        name: np.uint32(int(value, 16)).view(np.float32)
        for name, value in json.loads(header[prefix + "manifest"]).items()
    }
    layers = sorted({name[len(layer_name) : len(layer_name) + 2] for name in channels if name.startswith(layer_name)})
    mattes = {}
    for name in names:
        matte = np.zeros(next(iter(channels.values())).shape, dtype=np.float32)
        for layer in layers:
            for id_channel, coverage_channel in (("r", "g"), ("b", "a")):
                rank_ids = channels[f"{layer_name}{layer}.{id_channel}"]
                matte += np.where(rank_ids == ids[name], channels[f"{layer_name}{layer}.{coverage_channel}"], 0)
        mattes[name] = matte
    return mattes


def test_a_matte_read_back_from_the_exr_file_equals_the_objects_coverage(tmp_path) -> None:
    generator = np.random.default_rng(5)
    height, width, samples = 24, 32, 16
    names = ["Cube", "Sphere", "Plane", "Ground.001", "Vane"]
    hashes = np.array([name_hash(name)[1] for name in names], dtype=np.float32)
    # Regions of one object each with ragged edges where up to three objects and the background share a pixel.
    base = (np.arange(height * width) // 97 % len(names))[:, None]
    others = generator.integers(-1, len(names), (height * width, samples))
    sample_ids = np.where(generator.random(others.shape) < 0.7, base, others)
    sample_ids = np.where(generator.random(sample_ids.shape) < 0.1, -1, sample_ids)
    levels = 6
    columns = ranks(sample_ids, hashes, levels)
    layer = "ViewLayer.CryptoObject"
    channels = {
        name: columns[:, index].reshape(height, width) for index, name in enumerate(channel_names(layer, levels))
    }
    channels["ViewLayer.Combined.R"] = np.ones((height, width), dtype=np.float32)
    path = tmp_path / "frame.exr"
    write_multilayer_exr(path, channels, header=layer_header(layer, names))
    mattes = read_mattes(path, layer, names)
    for index, name in enumerate(names):
        coverage = ((sample_ids == index).sum(axis=1).astype(np.float32) / np.float32(samples)).reshape(height, width)
        assert np.array_equal(mattes[name], coverage), name
        assert coverage.any()


BLENDER = shutil.which("blender")

# Blender's compositor picks the matte out of the file alone: an Image-sourced Cryptomatte node, its Matte output
# written as a 32-bit EXR.
COMPOSITE = """
import bpy, sys
source, target, matte_id = sys.argv[sys.argv.index("--") + 1 :]
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = {width}, {height}, 100
scene.use_nodes = True
tree = scene.node_tree
tree.nodes.clear()
crypto = tree.nodes.new("CompositorNodeCryptomatteV2")
crypto.source = "IMAGE"
crypto.image = bpy.data.images.load(source)
crypto.layer_name = "ViewLayer.CryptoObject"  # as a user picks it (unset, 3.4 composites an empty matte)
crypto.matte_id = matte_id
composite = tree.nodes.new("CompositorNodeComposite")
tree.links.new(crypto.outputs["Matte"], composite.inputs["Image"])
settings = scene.render.image_settings
settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
scene.render.filepath = target
bpy.ops.render.render(write_still=True)
"""


@pytest.mark.skipif(
    BLENDER is None, reason="Debian's blender (3.4.1) is not installed: `make test` installs it with apt-get as root"
)
def test_blenders_cryptomatte_node_picks_the_same_matte_from_the_file(tmp_path) -> None:
    generator = np.random.default_rng(9)
    height, width, samples = 12, 20, 16
    # Two of the names have their ID's exponent moved (0 -> 1, 255 -> 254): Blender must agree on those too.
    names = ["Cube", *names_with_exponent({0}, 1), *names_with_exponent({255}, 1)]
    hashes = np.array([name_hash(name)[1] for name in names], dtype=np.float32)
    base = (np.arange(height * width) // 31 % len(names))[:, None]
    others = generator.integers(-1, len(names), (height * width, samples))
    sample_ids = np.where(generator.random(others.shape) < 0.6, base, others)
    layer = "ViewLayer.CryptoObject"
    columns = ranks(sample_ids, hashes, 6)
    channels = {name: columns[:, index].reshape(height, width) for index, name in enumerate(channel_names(layer, 6))}
    for channel in "RGBA":
        channels[f"ViewLayer.Combined.{channel}"] = np.ones((height, width), dtype=np.float32)
    source, target = tmp_path / "render.exr", tmp_path / "matte.exr"
    write_multilayer_exr(source, channels, header=layer_header(layer, names))
    command = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1"]
    command += ["--python-expr", COMPOSITE.format(width=width, height=height), "--"]
    command += [str(source), str(target), f"{names[1]},{names[2]}"]
    run = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and target.exists(), run.stdout[-2000:] + run.stderr[-2000:]
    matte = read_exr_channels(target)[0]["R"]
    hits = ((sample_ids == 1) | (sample_ids == 2)).sum(axis=1)
    expected = (hits.astype(np.float32) / np.float32(samples)).reshape(height, width)
    assert expected.any() and not expected.all()
    assert np.array_equal(matte, expected)


@pytest.mark.parametrize("levels", [2, 6, 10])
def test_a_scene_files_levels_give_cycles_layers_in_the_render_and_its_exr(levels: int) -> None:
    """render.cryptomatte_levels: the ranks each pixel keeps, in (levels + 1) // 2 layers of the render's passes and
    of the command line's EXR (ViewLayer.CryptoObject00.r ...), at 1 sample (written straight) and at 4 (ranked)."""
    from tracer.scene.loader import default_scene_dict, scene_from_dict
    from tracer.tracing.pass_files import exr_channels
    from tracer.workers.parallel import render

    document = default_scene_dict()
    document["render"].update(width=12, height=9, passes=["cryptomatte_object"], cryptomatte_levels=levels)
    layers = (levels + 1) // 2
    for samples in (1, 4):
        document["render"]["samples"] = samples
        scene = scene_from_dict(document)
        result = render(scene, workers=1)
        assert result.passes["cryptomatte_object"].shape == (9, 12, 4 * layers)
        channels, _ = exr_channels(scene, result.image, None, result.passes)
        crypto = sorted(name for name in channels if "Crypto" in name)
        assert crypto == sorted(channel_names("ViewLayer.CryptoObject", levels)), crypto
        assert crypto[-1] == f"ViewLayer.CryptoObject{layers - 1:02d}.r"  # sorted: a, b, g, r


def test_cryptomatte_names_rename_the_ids_and_the_manifest_and_bad_ones_are_refused() -> None:
    """render.cryptomatte_names: the IDs and the manifest under the names given (a Blender export's: its objects' and
    materials' Blender names, as Cycles hashes them); the scene's own where none is given; a name for nothing, an
    empty name or levels out of Blender's 1-16 are one line each."""
    from tracer.scene.loader import SceneError, default_scene_dict, scene_from_dict
    from tracer.tracing.pass_files import exr_channels
    from tracer.workers.parallel import render

    document = default_scene_dict()
    obj, material = document["objects"][0]["name"], next(iter(document["materials"]))
    document["render"].update(width=12, height=9, samples=4, passes=["cryptomatte_object", "cryptomatte_material"])
    document["render"]["cryptomatte_names"] = {"objects": {obj: "WV " + obj}, "materials": {material: "Brass"}}
    scene = scene_from_dict(document)
    assert scene.render.cryptomatte_names == (("material", material, "Brass"), ("object", obj, "WV " + obj))
    result = render(scene, workers=1)
    _, header = exr_channels(scene, result.image, None, result.passes)
    manifests = [json.loads(value) for key, value in header.items() if key.endswith("/manifest")]
    listed = set().union(*manifests)
    assert {"WV " + obj, "Brass"} <= listed and not {obj, material} & listed
    for name, kind in (("WV " + obj, "cryptomatte_object"), ("Brass", "cryptomatte_material")):
        ids = result.passes[kind][..., 0::2]
        assert (ids == np.float32(name_hash(name)[1])).any(), name
    for field, value, message in (
        ("cryptomatte_names", {"objects": {"nothing": "x"}}, "names no object of the scene"),
        ("cryptomatte_names", {"materials": {material: ""}}, "must map names to non-empty names"),
        ("cryptomatte_levels", 0, "must be >= 1"),
        ("cryptomatte_levels", 17, "must be <= 16"),
    ):
        bad = default_scene_dict()
        bad["render"][field] = value
        with pytest.raises(SceneError, match=message):
            scene_from_dict(bad)
