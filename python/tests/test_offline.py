"""The parts of the client that need no engine: the workflow builder and the mesh bytes."""

import json
import struct

import numpy as np
import pytest

import meshflow
from meshflow import Workflow, check, if_, run, while_


def test_builder_emits_the_engine_json():
    wf = (Workflow(transfer="auto")
          .run("remove-smallest-components")
          .run("laplacian-smoothing", iterations=2, keep_boundary=False)
          .while_(check("normal-instability") > 2, [run("laplacian-smoothing", iterations=1)],
                  max_iterations=5)
          .if_(check("is-manifold") == False,  # noqa: E712
               [run("remove-degenerate-triangles")], else_=[run("fill-holes", max_hole_edges=200)]))
    assert wf.to_dict() == {
        "transfer": "auto",
        "steps": [
            {"run": "remove-smallest-components"},
            {"run": "laplacian-smoothing", "params": {"iterations": 2, "keep-boundary": False}},
            {"while": {"check": "normal-instability", "op": ">", "value": 2},
             "do": [{"run": "laplacian-smoothing", "params": {"iterations": 1}}],
             "max-iterations": 5},
            {"if": {"check": "is-manifold", "op": "==", "value": False},
             "then": [{"run": "remove-degenerate-triangles"}],
             "else": [{"run": "fill-holes", "params": {"max-hole-edges": 200}}]},
        ],
    }


def test_builder_names_and_pins():
    assert run("taubin-smoothing", lambda_=0.5, mu=-0.53) == {
        "run": "taubin-smoothing", "params": {"lambda": 0.5, "mu": -0.53}}
    assert run("x", params={"odd_name": 1}, plugin="ab" * 6) == {
        "run": "x", "params": {"odd_name": 1}, "plugin": "abababababab"}
    c = (check("hole-count", plugin="cd" * 6) <= 3).to_dict()
    assert c == {"check": "hole-count", "op": "<=", "value": 3, "plugin": "cdcdcdcdcdcd"}
    assert while_(check("hole-count") != 0, run("fill-holes"))["do"] == [{"run": "fill-holes"}]
    assert if_(check("vertex-count") < 10, Workflow().run("a").run("b"))["then"] == [
        {"run": "a"}, {"run": "b"}]
    with pytest.raises(TypeError):
        bool(check("hole-count") > 0)


def test_workflow_round_trips_the_examples():
    from conftest import ROOT

    for path in (ROOT / "examples" / "workflows").glob("*.json"):
        d = json.loads(path.read_text())
        assert Workflow.load(path).to_dict() == (d if isinstance(d, dict) else {"steps": d})


def test_ply_and_raw_bytes():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float64)
    f = np.array([[0, 1, 2]])
    ply = meshflow.ply_bytes(v, f)
    head, body = ply.split(b"end_header\n")
    assert b"element vertex 3" in head and b"element face 1" in head
    assert len(body) == 3 * 12 + 13 and body[36] == 3
    raw = meshflow.raw_bytes(v, f)
    assert raw[:4] == b"MFR1" and struct.unpack("<II", raw[4:12]) == (3, 1)
    v2, f2 = meshflow.parse_raw(raw)
    assert v2.dtype == np.float32 and f2.dtype == np.uint32
    assert np.array_equal(v2, v.astype(np.float32)) and np.array_equal(f2, f)
    with pytest.raises(ValueError):
        meshflow.parse_raw(raw[:-1])
    with pytest.raises(ValueError):
        meshflow.ply_bytes(v, [[0, 1, 3]])


def test_a_raw_mesh_with_attributes_parses_and_says_what_it_carries():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    raw = meshflow.raw_bytes(v, [[0, 1, 2]])
    # The section as meshflow-mesh writes it: a colour per vertex, one texture name.
    section = b"attributes-v1" + struct.pack("<I", 1) + bytes([0, 0, 4])
    section += struct.pack("<I", 5) + b"color" + struct.pack("<Q", 12)
    section += bytes([255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128])
    section += struct.pack("<I", 0) + struct.pack("<I", 0) + struct.pack("<I", 1)
    section += struct.pack("<I", 8) + b"skin.png"
    v2, f2 = meshflow.parse_raw(raw + section)
    assert np.array_equal(v2, v) and f2.tolist() == [[0, 1, 2]]
    carried = meshflow.raw_attributes(raw + section)
    assert carried["vertex color"].dtype == np.uint8
    assert carried["vertex color"].tolist()[2] == [0, 0, 255, 128]
    assert carried["textures"] == ["skin.png"] and carried["materials"] == []
    assert meshflow.raw_attributes(raw) == {}
    for broken in (raw + section[:-1], raw + section + b"\0", raw + b"junk"):
        with pytest.raises(ValueError):
            meshflow.parse_raw(broken)
