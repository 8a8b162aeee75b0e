"""Mesh bytes in pure Python/numpy: binary PLY out, the engine's ``raw`` format in."""

from __future__ import annotations

import struct

import numpy as np

RAW_MAGIC = b"MFR1"
HASH_DOMAIN = b"meshflow-mesh-v1"


def as_arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Checks and converts to ``(V, 3) float32`` and ``(T, 3) uint32`` C-contiguous arrays."""
    v = np.ascontiguousarray(np.asarray(vertices, dtype=np.float32))
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), not {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must have shape (T, 3), not {f.shape}")
    if f.size and (not np.issubdtype(f.dtype, np.integer)):
        raise ValueError(f"faces must be integers, not {f.dtype}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"faces refer to vertices outside 0..{len(v) - 1}")
    if not np.all(np.isfinite(v)):
        raise ValueError("vertices hold a non-finite coordinate")
    return v, np.ascontiguousarray(f.astype(np.uint32))


def ply_bytes(vertices, faces) -> bytes:
    """A binary little-endian PLY of the triangle mesh (float32 x y z, uchar/int lists)."""
    v, f = as_arrays(vertices, faces)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment written by the meshflow Python client\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode("ascii")
    face_rec = np.empty(len(f), dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    face_rec["n"] = 3
    face_rec["i"] = f.astype("<i4")
    return header + v.astype("<f4").tobytes() + face_rec.tobytes()


ATTRIBUTES_TAG = b"attributes-v1"
_DOMAINS = ("vertex", "face", "corner")
_TYPES = ("<u1", "<i4", "<u4", "<f4", "<f8")


def parse_raw(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Decodes the engine's ``?format=raw``: ``MFR1``, u32 vertex and triangle counts, then
    3 f32 per vertex and 3 u32 per triangle, all little endian, then (for a mesh that
    carries colours, normals, …) its attributes, which :func:`raw_attributes` reads."""
    nv, nt, end = _raw_counts(data)
    if len(data) != end:
        raw_attributes(data)  # checks the section; a mesh without one must end here
    v = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=12).reshape(nv, 3).astype(np.float32)
    t = np.frombuffer(data, dtype="<u4", count=3 * nt, offset=12 + 12 * nv).reshape(nt, 3).astype(np.uint32)
    return v, t


def _raw_counts(data: bytes) -> tuple[int, int, int]:
    if len(data) < 12 or data[:4] != RAW_MAGIC:
        raise ValueError("not a meshflow raw mesh (no MFR1 header)")
    nv, nt = struct.unpack_from("<II", data, 4)
    end = 12 + 12 * nv + 12 * nt
    if len(data) < end or (len(data) > end and data[end:end + len(ATTRIBUTES_TAG)] != ATTRIBUTES_TAG):
        raise ValueError(f"raw mesh of {nv} vertices and {nt} triangles is {end} bytes, got {len(data)}")
    return nv, nt, end


def raw_attributes(data: bytes) -> dict[str, np.ndarray]:
    """What a raw mesh carries beyond positions and triangles, by ``"domain name"``
    (``"vertex color"``: ``(V, 4) uint8``; ``"corner texcoord"``: ``(3T, 2) float32``), each
    an array of one row per element in the type it came in. Material names, libraries and
    textures are under ``"materials"``, ``"libraries"`` and ``"textures"`` as lists."""
    nv, nt, at = _raw_counts(data)
    found: dict = {}
    if at == len(data):
        return found

    def take(n: int) -> bytes:
        nonlocal at
        if at + n > len(data):
            raise ValueError("the raw mesh's attributes are cut short")
        chunk = data[at:at + n]
        at += n
        return chunk

    def u32() -> int:
        return struct.unpack("<I", take(4))[0]

    take(len(ATTRIBUTES_TAG))
    for _ in range(u32()):
        domain, kind, components = take(3)
        if domain >= len(_DOMAINS) or kind >= len(_TYPES) or not 1 <= components <= 4:
            raise ValueError("the raw mesh's attributes are malformed")
        name = take(u32()).decode("utf-8")
        (numbers,) = struct.unpack("<Q", take(8))
        elements = (nv, nt, 3 * nt)[domain]
        if numbers != elements * components:
            raise ValueError(f"attribute {name} has {numbers} numbers for {elements} elements")
        dtype = np.dtype(_TYPES[kind])
        values = np.frombuffer(take(numbers * dtype.itemsize), dtype=dtype)
        found[f"{_DOMAINS[domain]} {name}"] = values.reshape(elements, components).copy()
    for key in ("materials", "libraries", "textures"):
        found[key] = [take(u32()).decode("utf-8") for _ in range(u32())]
    if at != len(data):
        raise ValueError("bytes after the raw mesh's attributes")
    return found


def raw_bytes(vertices, faces) -> bytes:
    """The ``raw`` encoding of a mesh (the inverse of :func:`parse_raw`)."""
    v, f = as_arrays(vertices, faces)
    return RAW_MAGIC + struct.pack("<II", len(v), len(f)) + v.astype("<f4").tobytes() + f.astype("<u4").tobytes()


def content_hash_of_raw(data: bytes) -> str | None:
    """meshflow's canonical content hash of a raw mesh: BLAKE3 of ``meshflow-mesh-v1``
    followed by everything after the magic. ``None`` when the ``blake3`` package is missing."""
    try:
        import blake3  # type: ignore
    except ImportError:
        return None
    h = blake3.blake3(HASH_DOMAIN)
    h.update(memoryview(data)[4:])
    return h.hexdigest()


def content_hash(vertices, faces) -> str | None:
    """The content hash ``meshflow hash`` prints for this mesh (``None`` without ``blake3``)."""
    return content_hash_of_raw(raw_bytes(vertices, faces))
