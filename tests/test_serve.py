"""The Grasshopper Hops endpoint over HTTP on localhost, with Hops' own JSON payloads: a
barrel-vault mesh (in metres) in, panel outlines, developed meshes and verdicts out."""

from __future__ import annotations

import json
import threading
import urllib.error
import urllib.request

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")


def vault_mesh(radius: float = 2.0, length: float = 2.4, n: int = 16) -> object:
    """A half cylinder of quads, metres (as a Rhino document in m would hold it)."""
    mesh = rhino3dm.Mesh()
    t = np.linspace(0.0, np.pi, n + 1)
    x = np.linspace(0.0, length, 7)
    for xi in x:
        for ti in t:
            mesh.Vertices.Add(float(xi), float(radius * np.cos(ti)), float(radius * np.sin(ti)))
    for i in range(len(x) - 1):
        for j in range(n):
            a = i * (n + 1) + j
            mesh.Faces.AddFace(a, a + 1, a + n + 2, a + n + 1)
    return mesh


def payload(**values) -> bytes:
    """A Hops solve request: one item per input, Rhino geometry encoded as Rhino does."""
    items = []
    for name, value in values.items():
        if isinstance(value, rhino3dm.Mesh):
            kind, data = "Rhino.Geometry.Mesh", json.dumps(value.Encode())
        elif isinstance(value, float):
            kind, data = "System.Double", json.dumps(value)
        else:
            kind, data = "System.String", json.dumps(value)
        items.append({"ParamName": name, "InnerTree": {"{0}": [{"type": kind, "data": data}]}})
    return json.dumps({"values": items}).encode()


@pytest.fixture(scope="module")
def endpoint():
    from fabpanel.serve import server

    httpd = server("127.0.0.1", 0)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


def solve(endpoint: str, path: str, body: bytes) -> dict:
    request = urllib.request.Request(endpoint + path, data=body, method="POST")
    with urllib.request.urlopen(request, timeout=300) as response:
        return json.loads(response.read())


def outputs(answer: dict) -> dict:
    return {
        v["ParamName"]: [item["data"] for item in v["InnerTree"]["0"]] for v in answer["values"]
    }


def test_components_are_listed(endpoint):
    with urllib.request.urlopen(endpoint + "/", timeout=30) as response:
        listed = json.loads(response.read())
    assert {c["Uri"] for c in listed} == {"/inspect", "/panelize", "/develop", "/export"}
    with urllib.request.urlopen(endpoint + "/panelize", timeout=30) as response:
        panelize = json.loads(response.read())
    assert [i["Name"] for i in panelize["Inputs"]] == ["Surface", "Units", "Panel size", "Method"]


def test_inspect_reads_the_mesh_in_the_documents_units(endpoint):
    found = outputs(solve(endpoint, "/inspect", payload(Surface=vault_mesh(), Units="m")))
    # a half cylinder of radius 2 m, 2.4 m long: pi r l, less the facets' chord shortfall
    assert float(found["Area"][0]) == pytest.approx(np.pi * 2.0 * 2.4, rel=0.01)
    assert int(found["Loops"][0]) == 1 and int(found["Openings"][0]) == 0


def test_panelize_returns_closed_outlines_in_the_documents_units(endpoint):
    answer = solve(
        endpoint,
        "/panelize",
        payload(Surface=vault_mesh(), Units="m", **{"Panel size": 1.2}, Method="grid"),
    )
    found = outputs(answer)
    curves = [rhino3dm.CommonObject.Decode(json.loads(data)) for data in found["Panels"]]
    assert len(curves) == len(found["Ids"]) >= 4
    for curve in curves:
        assert curve.IsClosed
        corner = curve.PointAt(curve.Domain.T0)
        # on the vault, in metres
        assert np.hypot(corner.Y, corner.Z) == pytest.approx(2.0, abs=0.01)
    assert "panels (grid)" in json.loads(found["Verdict"][0])


def test_develop_returns_developed_meshes_and_verdicts(endpoint):
    answer = solve(
        endpoint,
        "/develop",
        payload(Surface=vault_mesh(n=32), Units="m", **{"Panel size": 1.2}, Method="global"),
    )
    found = outputs(answer)
    meshes = [rhino3dm.CommonObject.Decode(json.loads(data)) for data in found["Panels"]]
    assert meshes and all(m.Faces.Count > 0 for m in meshes)
    assert len(found["Classes"]) == len(meshes)
    assert float(found["Strain"][0]) <= 5e-4  # the default strain tolerance
    assert "developable" in json.loads(found["Verdict"][0])


def test_bad_units_come_back_as_the_components_error(endpoint):
    with pytest.raises(urllib.error.HTTPError) as error:
        solve(endpoint, "/inspect", payload(Surface=vault_mesh(), Units="inch"))
    assert "give m, cm or mm" in error.value.read().decode()


def test_export_runs_the_pipeline_into_the_folder(endpoint, tmp_path):
    out = tmp_path / "hops-out"
    answer = solve(
        endpoint,
        "/export",
        payload(
            Surface=vault_mesh(n=32), Units="m", **{"Panel size": 1.2}, Folder=str(out),
            Until="build",
        ),
    )  # fmt: skip
    found = outputs(answer)
    assert json.loads(found["Folder"][0]) == str(out)
    assert (out / "manifest.json").is_file() and (out / "model" / "assembly.step").is_file()
    verdicts = [json.loads(v) for v in found["Verdicts"]]
    assert any(v.startswith("Buildable: PASS") for v in verdicts), verdicts
    assert int(found["Errors"][0]) == 0
