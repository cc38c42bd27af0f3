"""Binary glTF made compact without changing the geometry: triangle indices in 16 bits.

trimesh writes every index accessor as unsigned 32-bit integers. A part's tessellation has a
few hundred to a few thousand vertices, so its indices fit in 16 bits (glTF's componentType
5123, allowed for indices by the specification), and the indices are two thirds of the
preview's bytes. :func:`narrow_indices` rewrites a GLB's binary chunk with the index
accessors that fit in 16 bits narrowed, every buffer view re-laid at a 4-byte boundary, and
the JSON chunk updated; positions and everything else are copied byte for byte.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from ..errors import KernelError

#: glTF componentType codes
UINT16, UINT32 = 5123, 5125
#: GLB header and chunk magic numbers (glTF 2.0, binary container)
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942


def narrow_indices(glb: bytes) -> bytes:
    """``glb`` with every 32-bit index accessor whose largest index fits in 16 bits stored in
    16 bits (module docstring)."""
    document, binary = _chunks(glb)
    views = document.get("bufferViews", [])
    accessors = document.get("accessors", [])
    index_accessors = {
        p["indices"] for m in document.get("meshes", []) for p in m["primitives"] if "indices" in p
    }
    users: dict[int, list[int]] = {}
    for a, accessor in enumerate(accessors):
        if "bufferView" in accessor:
            users.setdefault(accessor["bufferView"], []).append(a)
    out, offset = [], 0
    for v, view in enumerate(views):
        start = view.get("byteOffset", 0)
        data = binary[start : start + view["byteLength"]]
        narrow = _narrowable(users.get(v, []), accessors, index_accessors)
        if narrow is not None:
            data = np.frombuffer(data, "<u4").astype("<u2").tobytes()
            narrow["componentType"] = UINT16
        pad = (-offset) % 4
        out.append(b"\0" * pad + data)
        offset += pad
        view["byteOffset"], view["byteLength"] = offset, len(data)
        offset += len(data)
    body = b"".join(out)
    body += b"\0" * ((-len(body)) % 4)
    if document.get("buffers"):
        document["buffers"][0]["byteLength"] = len(body)
    return _pack(document, body)


def _narrowable(users: list[int], accessors: list[dict], index_accessors: set[int]) -> dict | None:
    """The one accessor of a buffer view (its accessors ``users``) if it is a 32-bit index
    accessor at the view's start whose largest index fits in 16 bits, else None."""
    if len(users) != 1 or users[0] not in index_accessors:
        return None
    accessor = accessors[users[0]]
    fits = max(accessor.get("max", [1 << 16])) < 1 << 16
    if accessor.get("componentType") != UINT32 or accessor.get("byteOffset", 0) or not fits:
        return None
    return accessor


def _chunks(glb: bytes) -> tuple[dict, bytes]:
    """The JSON document and the binary chunk of a GLB."""
    magic, version, length = struct.unpack_from("<III", glb, 0)
    if magic != GLB_MAGIC or version != 2 or length != len(glb):
        raise KernelError("not a glTF 2.0 binary file")
    size, kind = struct.unpack_from("<II", glb, 12)
    if kind != JSON_CHUNK:
        raise KernelError("a glTF binary file whose first chunk is not JSON")
    document = json.loads(glb[20 : 20 + size])
    binary = b""
    at = 20 + size
    if at < len(glb):
        bin_size, bin_kind = struct.unpack_from("<II", glb, at)
        if bin_kind == BIN_CHUNK:
            binary = glb[at + 8 : at + 8 + bin_size]
    return document, binary


def _pack(document: dict, body: bytes) -> bytes:
    """A GLB of a JSON document and a binary chunk (both padded to 4 bytes)."""
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * ((-len(text)) % 4)
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if body:
        chunks += struct.pack("<II", len(body), BIN_CHUNK) + body
    return struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks
