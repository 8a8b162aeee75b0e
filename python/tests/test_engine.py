"""The client against a real `meshflow up --hosts 2` on loopback."""

import json
import subprocess

import numpy as np
import pytest

import meshflow
from conftest import BUNNY, REPAIR, read_obj
from meshflow import Workflow, check, run


def test_services(engine):
    names = {s["name"]: s for s in engine.services()}
    assert "laplacian-smoothing" in names and "hole-count" in names
    assert names["laplacian-smoothing"]["kind"] == "filter" and names["laplacian-smoothing"]["hosts"]


def test_repair_of_numpy_arrays_matches_meshflow_run(engine, bunny, binary, tmp_path):
    vertices, faces = bunny
    r = engine.run(REPAIR, (vertices, faces)).wait(progress=False)
    assert r.status == "completed", r.record.get("error")
    # The arrays went up as a PLY holding the same mesh as the file.
    file_hash = subprocess.run([binary, "hash", str(BUNNY)], check=True, capture_output=True,
                               text=True).stdout.split()[0]
    assert r.record["input"]["hash"] == file_hash
    assert meshflow.content_hash(vertices, faces) == file_hash
    # The same workflow on the same file with `meshflow run` (its own engine and hosts).
    report = tmp_path / "run.json"
    subprocess.run([binary, "run", str(REPAIR), str(BUNNY), "--hosts", "2", "--report", str(report),
                    "-o", str(tmp_path / "cli.ply")], check=True, capture_output=True)
    cli_hash = json.loads(report.read_text())["result"]["hash"]
    assert r.result_hash == cli_hash
    v, f = r.result(verify=True)
    assert v.dtype == np.float32 and f.dtype == np.uint32
    assert meshflow.content_hash(v, f) == cli_hash
    assert len(r.steps) == 4 and [s["service"] for s in r.steps][1] == "laplacian-smoothing"
    assert "<table>" in r._repr_html_() and "laplacian-smoothing" in r._repr_html_()
    # A download in another format, hashed by the CLI.
    out = r.download(tmp_path / "result.obj")
    assert subprocess.run([binary, "hash", str(out)], check=True, capture_output=True,
                          text=True).stdout.split()[0] == cli_hash
    again = r.rerun().wait(progress=False)
    assert again.comparison()["identical"] is True


def test_batch_of_three(engine, bunny, tmp_path):
    v, f = bunny
    scaled = (v * 2.0, f)
    wf = Workflow().run("laplacian-smoothing", iterations=2).while_(
        check("hole-count") > 0, [run("fill-holes")], max_iterations=3)
    rows = engine.batch(wf, [BUNNY, (v, f), scaled])
    assert len(rows) == 3
    assert [r["status"] for r in rows] == ["completed"] * 3, rows
    assert rows[0]["result_hash"] == rows[1]["result_hash"]  # the file and its arrays
    assert rows[2]["result_hash"] != rows[0]["result_hash"]
    assert all(r["vertices_in"] == len(v) for r in rows)
    assert any(k.startswith("hole-count") for k in rows[0]["checks"])


def test_refused_workflow_raises_with_the_engine_code(engine, bunny):
    with pytest.raises(meshflow.MeshflowError) as e:
        engine.run(Workflow().run("laplacian-smoothin"), bunny)
    assert e.value.code == "invalid-workflow" and e.value.status == 400
    assert "did you mean" in e.value.message
    with pytest.raises(meshflow.MeshflowError) as e:
        engine.run(Workflow().run("laplacian-smoothing", iterations=0), bunny)
    assert e.value.code == "invalid-workflow"
    with pytest.raises(meshflow.MeshflowError) as e:
        engine.run(Workflow().run("laplacian-smoothing"))
    assert e.value.code == "no-input"
    with pytest.raises(meshflow.MeshflowError) as e:
        meshflow.Engine(engine.url, token="wrong-token-wrong-token").services()
    assert e.value.code == "unauthorized" and e.value.status == 401


def test_cancelled_run_reads_cancelled(engine, bunny):
    forever = Workflow().while_(check("vertex-count") > 0,
                                [run("laplacian-smoothing", iterations=50)], max_iterations=10000)
    r = engine.run(forever, bunny)
    r.cancel()
    assert r.status == "cancelled"
    assert r.wait(progress=False, timeout=30).status == "cancelled"
    with pytest.raises(meshflow.RunFailed) as e:
        r.result()
    assert e.value.run_status == "cancelled"
    with pytest.raises(meshflow.MeshflowError) as e:
        r.cancel()
    assert e.value.code == "finished"


def test_trimesh_in_and_out(engine, bunny):
    trimesh = pytest.importorskip("trimesh")
    v, f = bunny
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    r = engine.run(Workflow().run("taubin-smoothing", iterations=3), mesh).wait(progress=False)
    out = r.result_trimesh()
    assert isinstance(out, trimesh.Trimesh) and out.vertices.shape == v.shape
    assert np.array_equal(out.faces, f)
    assert meshflow.content_hash(out.vertices.astype(np.float32), out.faces) == r.result_hash
