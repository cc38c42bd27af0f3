"""The GLB preview's 16-bit indices: the same geometry, fewer bytes, 32 bits kept where needed."""

import json
import struct

import numpy as np
import pytest
import trimesh

from fabpanel.errors import KernelError
from fabpanel.model.glb import UINT16, UINT32, narrow_indices


def _document(glb: bytes) -> dict:
    size = struct.unpack_from("<I", glb, 12)[0]
    return json.loads(glb[20 : 20 + size])


def test_indices_that_fit_go_to_16_bits_and_the_geometry_stays():
    small = trimesh.creation.icosphere(subdivisions=2)  # 162 vertices
    large = trimesh.creation.icosphere(subdivisions=7)  # 163842 vertices: needs 32 bits
    large.apply_translation([5.0, 0.0, 0.0])
    odd = trimesh.Trimesh(small.vertices + 9.0, small.faces[:-1], process=False)  # odd count
    scene = trimesh.Scene()
    for name, mesh in (("small", small), ("large", large), ("odd", odd)):
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    before = scene.export(file_type="glb")
    after = narrow_indices(before)
    assert len(after) < len(before)
    document = _document(after)
    kinds = {
        document["meshes"][n["mesh"]]["name"]: document["accessors"][
            document["meshes"][n["mesh"]]["primitives"][0]["indices"]
        ]["componentType"]
        for n in document["nodes"]
        if "mesh" in n
    }
    assert kinds == {"small": UINT16, "large": UINT32, "odd": UINT16}
    assert all(view["byteOffset"] % 4 == 0 for view in document["bufferViews"])
    assert struct.unpack_from("<I", after, 8)[0] == len(after)
    read_before = trimesh.load(trimesh.util.wrap_as_stream(before), file_type="glb")
    read_after = trimesh.load(trimesh.util.wrap_as_stream(after), file_type="glb")
    assert sorted(read_after.geometry) == ["large", "odd", "small"]
    for name, mesh in read_before.geometry.items():
        np.testing.assert_array_equal(read_after.geometry[name].faces, mesh.faces)
        np.testing.assert_array_equal(read_after.geometry[name].vertices, mesh.vertices)


def test_a_file_that_is_not_binary_gltf_is_refused():
    with pytest.raises(KernelError, match="glTF"):
        narrow_indices(b"PK\x03\x04" + bytes(40))
