"""The Python plugin template (examples/plugin-template-python): its algorithm in plain
CPython and, built with componentize-py, as a component — against the built-in
`taubin-smoothing` on the bunny, and uploaded to one host of `meshflow up` whose step the
other host replays. And a filter declared to run in blocks (blocks_plugin/), run by a host.

The components are built once per session by the template's Makefile into target/ (its venv
too: target/python-venv-plugin), so a fresh clone builds them again and a later session whose
sources did not change reuses them; the hosts and the CLI share the compiled artefacts
(MESHFLOW_CACHE_DIR, see conftest.py)."""

import json
import os
import re
import subprocess
import sys
import time

import numpy as np
import pytest

import meshflow
from conftest import BUNNY, ROOT, read_obj
from meshflow import Workflow, check, run

TEMPLATE = ROOT / "examples" / "plugin-template-python"
SDK = ROOT / "sdk" / "python"
PLUGIN_DIR = ROOT / "target" / "tmp" / "python-plugin"


def componentize(app_dir, wasm):
    """`wasm` built from `app_dir`'s app.py by the template's Makefile (make rebuilds it only
    when that folder, the SDK or the WIT changed)."""
    PLUGIN_DIR.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    made = subprocess.run(["make", "-C", str(app_dir), "-f", str(TEMPLATE / "Makefile"),
                           f"VENV={ROOT / 'target' / 'python-venv-plugin'}", f"MESHFLOW_WIT={ROOT / 'wit'}",
                           f"MESHFLOW_SDK={SDK}", f"OUT={wasm}"], capture_output=True, text=True)
    assert made.returncode == 0, f"make of {app_dir} failed:\n{made.stdout}\n{made.stderr}"
    print(f"\n{wasm.name} {wasm.stat().st_size / 1e6:.1f} MB, make {time.monotonic() - t0:.1f} s")
    return wasm


@pytest.fixture(scope="session")
def python_plugin():
    return componentize(TEMPLATE, PLUGIN_DIR / "py.wasm")


@pytest.fixture(scope="session")
def blocks_plugin():
    return componentize(ROOT / "python" / "tests" / "blocks_plugin", PLUGIN_DIR / "blocks.wasm")


def apply(binary, service, mesh, out, *args):
    """`meshflow apply … --json`: (its summary, wall seconds)."""
    t0 = time.monotonic()
    answer = subprocess.run([binary, "apply", *args, service, str(mesh), "-o", str(out), "--json"],
                            capture_output=True, text=True)
    assert answer.returncode == 0, answer.stderr
    return json.loads(answer.stdout), time.monotonic() - t0


def within_a_millionth_of_the_diagonal(a, b):
    diagonal = float(np.linalg.norm(b.max(axis=0) - b.min(axis=0)))
    worst = float(np.abs(a.astype(np.float64) - b.astype(np.float64)).max())
    assert worst <= 1e-6 * diagonal, (worst, diagonal)
    return worst


def test_the_python_algorithm_matches_the_builtin(binary, bunny, tmp_path):
    sys.path[:0] = [str(TEMPLATE), str(SDK)]
    try:
        import taubin
    finally:
        del sys.path[:2]
    v, f = bunny
    smoothed = taubin.smooth(v.reshape(-1).tolist(), f.reshape(-1).tolist(), 0.5, -0.53, 10)
    ours = np.frombuffer(smoothed, dtype=np.float32).reshape(-1, 3)
    apply(binary, "taubin-smoothing", BUNNY, tmp_path / "builtin.obj")
    within_a_millionth_of_the_diagonal(ours, read_obj(tmp_path / "builtin.obj")[0])


def test_the_python_component_matches_the_builtin(binary, python_plugin, tmp_path):
    ours, first = apply(binary, "taubin-smoothing-py", BUNNY, tmp_path / "py.obj",
                        "--plugin", str(python_plugin))
    theirs, _ = apply(binary, "taubin-smoothing", BUNNY, tmp_path / "builtin.obj")
    worst = within_a_millionth_of_the_diagonal(read_obj(tmp_path / "py.obj")[0],
                                               read_obj(tmp_path / "builtin.obj")[0])
    assert ours["input_hash"] == theirs["input_hash"] and ours["edits"] > 0
    print(f"\nfirst apply {first:.1f} s (load + run), run {ours['timings_ms']['run']:.1f} ms vs "
          f"built-in {theirs['timings_ms']['run']:.1f} ms, worst difference {worst:g}, hashes "
          f"{'equal' if ours['output_hash'] == theirs['output_hash'] else 'differ'}")


def test_the_python_component_runs_on_partitions_to_its_whole_mesh_hash(binary, python_plugin,
                                                                         tmp_path):
    # The template declares reach = 2 · iterations (world block-plugin): cut into cores of
    # 500 triangles, the bunny's 3,674 give several partitions, each in a sandbox of its own.
    whole, _ = apply(binary, "taubin-smoothing-py", BUNNY, tmp_path / "whole.obj",
                     "--plugin", str(python_plugin), "--param", "iterations=2")
    assert whole["partitions"] is None
    parts, _ = apply(binary, "taubin-smoothing-py", BUNNY, tmp_path / "parts.obj",
                     "--plugin", str(python_plugin), "--param", "iterations=2",
                     "--max-partition-triangles", "500")
    assert parts["partitions"]["count"] >= 5 and parts["partitions"]["rings"] == 4, parts
    assert parts["output_hash"] == whole["output_hash"] != whole["input_hash"]


def test_a_python_filter_declared_in_blocks_runs_block_by_block(binary, blocks_plugin, tmp_path):
    # The host asks, and the filter declares blocks of 1,000 triangles: the bunny's 3,674 run
    # block by block, each as a mesh of its own, whose border is a boundary the filter keeps.
    plugin = ("--plugin", str(blocks_plugin))
    whole, _ = apply(binary, "lift-py", BUNNY, tmp_path / "whole.obj", *plugin)
    assert whole["partitions"] is None and whole["report"] == "lifted 1839 of 1839 vertices"
    blocked, _ = apply(binary, "lift-in-blocks-py", BUNNY, tmp_path / "blocks.obj", *plugin)
    assert blocked["partitions"]["count"] >= 3 and blocked["partitions"]["rings"] == 0, blocked
    shared = int(re.search(r"the (\d+) vertices they share kept", blocked["report"]).group(1))
    # The bunny is closed: the whole run lifts every vertex, the blocks all but those they
    # share, which stay where they were.
    lifted, kept = read_obj(tmp_path / "whole.obj")[0], read_obj(tmp_path / "blocks.obj")[0]
    differ = (lifted != kept).any(axis=1)
    assert differ.sum() == shared > 0
    assert (lifted[differ][:, :2] == kept[differ][:, :2]).all()
    assert np.allclose(lifted[differ][:, 2] - kept[differ][:, 2], 0.01, rtol=1e-3)
    # Run again on a host with other limits: the same blocks, the same hash.
    again, _ = apply(binary, "lift-in-blocks-py", BUNNY, tmp_path / "again.obj", *plugin,
                     "--max-partition-triangles", "500", "--memory-cap", "1024")
    assert again["output_hash"] == blocked["output_hash"] != whole["output_hash"]
    # Declared, but 0 triangles: none, so whole, as the filter without the declaration.
    zero, _ = apply(binary, "lift-in-blocks-py", BUNNY, tmp_path / "zero.obj", *plugin,
                    "--param", "block-triangles=0")
    assert zero["partitions"] is None and zero["output_hash"] == whole["output_hash"]


def wait_until_idle(engine, timeout=60.0):
    """No host runs or has assigned tasks: the planner then breaks ties by registration."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if all(h["running"] == 0 and h["assigned"] == 0 for h in engine.hosts()):
            return
        time.sleep(0.1)
    raise TimeoutError(f"hosts still busy: {engine.hosts()}")


def test_uploaded_to_one_host_its_step_is_replayed_on_the_other_to_the_same_hash(
        engine, cluster, binary, python_plugin, tmp_path):
    hosts = [h["url"] for h in engine.hosts()]
    assert len(hosts) == 2, hosts
    # Unpinned built-in steps are planned on the first registered host (placement `load`,
    # both idle), so the plugin goes to the other one: its step's result must then travel to
    # the first.
    producer, replayer = hosts[1], hosts[0]
    uploaded = engine.upload_plugin(python_plugin, host=producer, upload_token=cluster.upload_token)
    digest = uploaded["digest"]
    assert "taubin-smoothing-py" in uploaded["new"] + uploaded["present"], uploaded
    offered = {s["name"]: s for s in engine.services()}
    assert offered["taubin-smoothing-py"]["hosts"] == [producer]

    wf = (Workflow(transfer="replay", placement="load")
          .run("laplacian-smoothing", iterations=2)
          .run("taubin-smoothing-py", iterations=5, plugin=digest)
          .if_(check("hole-count") > 0, [run("fill-holes")], else_=[run("laplacian-smoothing")]))
    wait_until_idle(engine)
    r = engine.run(wf, BUNNY).wait(progress=False, timeout=600)
    assert r.status == "completed", r.record.get("error")
    steps = r.steps
    assert [s["service"] for s in steps][:3] == ["laplacian-smoothing", "taubin-smoothing-py",
                                                 "hole-count"], steps
    py, after = steps[1], steps[2:]
    assert py["host"] == producer and py["plugin"] == digest
    # A later step runs on the other host, or, while that host is still re-running the
    # Python step, where the mesh is (code moved to the data: the record names the host it
    # was planned on). Either way the other host takes the Python step by replay.
    for s in after:
        moved = s.get("moved")
        assert s["host"] == replayer or (s["host"] == producer and moved
                                         and moved["planned"] == replayer), s
    assert after[0]["input_hash"] == py["output_hash"]
    # The other host took the Python step by re-running it (the component fetched from the
    # producer by digest): the engine fails a transfer whose answer is not the announced
    # hash, and the host falls back (`fallback`) when its replay reaches another mesh.
    taken = [t for t in py["transfers"] if t["host"] == replayer]
    assert len(taken) == 1, py["transfers"]
    assert taken[0]["asked"] == "replay" and taken[0]["via"] == "replay", taken[0]
    assert taken[0]["error"] is None and taken[0]["fallback"] is None, taken[0]
    assert "claims" not in py and "verdict" not in py
    print(f"\nthe Python step: {py['compute_ms']:.0f} ms on {producer}, replayed on {replayer} "
          f"in {taken[0]['download_ms'] + taken[0]['apply_ms']:.0f} ms ({taken[0]['bytes']} bytes "
          f"of replay; the component fetched by digest and loaded)")
    replay_plugins = cluster.data / f"host-{hosts.index(replayer)}" / "replay-plugins"
    assert (replay_plugins / f"{digest}.wasm").is_file(), list(replay_plugins.iterdir())

    # The same chain locally, one `meshflow apply` at a time.
    s0, _ = apply(binary, "laplacian-smoothing", BUNNY, tmp_path / "s0.ply", "--param", "iterations=2")
    s1, _ = apply(binary, "taubin-smoothing-py", tmp_path / "s0.ply", tmp_path / "s1.ply",
                  "--plugin", str(python_plugin), "--param", "iterations=5")
    holes = json.loads(subprocess.run([binary, "check", "hole-count", str(tmp_path / "s1.ply"), "--json"],
                                      check=True, capture_output=True, text=True).stdout)["value"]
    last = "fill-holes" if holes > 0 else "laplacian-smoothing"
    s2, _ = apply(binary, last, tmp_path / "s1.ply", tmp_path / "s2.ply")
    assert [steps[0]["output_hash"], py["output_hash"]] == [s0["output_hash"], s1["output_hash"]]
    assert after[0]["value"] == holes and after[1]["service"] == last
    assert r.result_hash == s2["output_hash"]
    v, f = r.result()
    assert meshflow.content_hash(v, f) == s2["output_hash"]


def test_upload_plugin_refusals_carry_the_engines_code(engine, cluster, python_plugin, tmp_path):
    hosts = [h["url"] for h in engine.hosts()]
    with pytest.raises(meshflow.MeshflowError) as e:
        engine.upload_plugin(python_plugin, host="http://127.0.0.1:9", upload_token=cluster.upload_token)
    assert e.value.code == "unknown-host" and e.value.status == 400
    # A small body: with the 18 MB component the host answers 401 before reading it all,
    # and the engine reports the broken pipe instead (502 host-failed).
    stub = tmp_path / "stub.wasm"
    stub.write_bytes(b"\0asm\x0d\0\x01\0")
    with pytest.raises(meshflow.MeshflowError) as e:
        engine.upload_plugin(stub, host=hosts[0], upload_token="not-the-upload-token")
    assert e.value.code == "host-unauthorized" and e.value.status == 403
    offered = {s["name"]: s["hosts"] for s in engine.services()}
    assert hosts[0] not in offered.get("taubin-smoothing-py", [])


def test_plugin_new_writes_a_python_project_whose_services_pass_natively(binary, tmp_path):
    subprocess.run([binary, "plugin", "new", "my-py", "--lang", "python", "--dir", "p"],
                   cwd=tmp_path, check=True, capture_output=True)
    project = tmp_path / "p"
    for name in ("Makefile", "app.py", "taubin.py", "test_app.py", "README.md", "wit/meshflow.wit",
                 "meshflow-sdk/meshflow_plugin/__init__.py"):
        assert (project / name).is_file(), name
    makefile = (project / "Makefile").read_text()
    assert "MESHFLOW_WIT ?= wit" in makefile and "OUT ?= my-py.wasm" in makefile
    env = dict(os.environ, PYTHONPATH=f"{project}{os.pathsep}{project / 'meshflow-sdk'}")
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_app.py"],
                   cwd=project, env=env, check=True, capture_output=True)
