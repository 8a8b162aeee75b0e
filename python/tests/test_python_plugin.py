"""The Python plugin template (examples/plugin-template-python) against the built-in
`taubin-smoothing` on the bunny.

The algorithm in plain CPython always runs (fast). Building the component (componentize-py,
~20 s) and its first load (compiling 18 MB of wasm, ~30 s in a debug binary) take about a
minute, so that part runs only with MESHFLOW_TEST_PYTHON_PLUGIN=1."""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import BUNNY, ROOT, read_obj

TEMPLATE = ROOT / "examples" / "plugin-template-python"
SDK = ROOT / "sdk" / "python"


def builtin_taubin(binary, tmp_path, plugin_args=(), service="taubin-smoothing"):
    out = tmp_path / f"{service}.obj"
    t0 = time.monotonic()
    answer = subprocess.run([binary, "apply", *plugin_args, service, str(BUNNY), "-o", str(out), "--json"],
                            check=True, capture_output=True, text=True)
    wall = time.monotonic() - t0
    return read_obj(out)[0], json.loads(answer.stdout), wall


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
    theirs, _, _ = builtin_taubin(binary, tmp_path)
    within_a_millionth_of_the_diagonal(ours, theirs)


@pytest.mark.skipif(os.environ.get("MESHFLOW_TEST_PYTHON_PLUGIN") != "1",
                    reason="builds a componentize-py component (~1 min): MESHFLOW_TEST_PYTHON_PLUGIN=1")
def test_the_python_component_matches_the_builtin(binary, tmp_path):
    venv = ROOT / "target" / "python-venv-plugin"
    wasm = tmp_path / "py.wasm"
    t0 = time.monotonic()
    subprocess.run(["make", "-C", str(TEMPLATE), f"VENV={venv}", f"OUT={wasm}"], check=True,
                   capture_output=True)
    build = time.monotonic() - t0
    ours, report, first = builtin_taubin(binary, tmp_path, ("--plugin", str(wasm)), "taubin-smoothing-py")
    theirs, builtin, _ = builtin_taubin(binary, tmp_path)
    worst = within_a_millionth_of_the_diagonal(ours, theirs)
    print(f"\npy.wasm {wasm.stat().st_size / 1e6:.1f} MB, build {build:.1f} s, first apply "
          f"{first:.1f} s (compile + run), run {report['timings_ms']['run']:.1f} ms vs built-in "
          f"{builtin['timings_ms']['run']:.1f} ms, worst difference {worst:g}, "
          f"hashes {'equal' if report['output_hash'] == builtin['output_hash'] else 'differ'}")


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
