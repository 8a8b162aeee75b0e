"""Fixtures: a `meshflow up --hosts 2` cluster on loopback for the session, the bunny as
numpy arrays (read by a tiny OBJ reader), the meshflow binary.

Compiled components are cached under target/ (MESHFLOW_CACHE_DIR, unless given, the folder
tests/cpp_sdk.rs uses): every `meshflow` this session starts compiles a component once, and
a fresh clone compiles again."""

from __future__ import annotations

import os
import re
import subprocess
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

import meshflow

ROOT = Path(__file__).resolve().parents[2]
BUNNY = ROOT / "examples" / "data" / "bunny.obj"
REPAIR = ROOT / "examples" / "workflows" / "repair.json"
os.environ.setdefault("MESHFLOW_CACHE_DIR", str(ROOT / "target" / "tmp" / "components"))


class Cluster(NamedTuple):
    url: str
    token: str
    upload_token: str
    # `up --data`: host i keeps its files in data/host-{i}.
    data: Path


def meshflow_bin() -> str:
    b = os.environ.get("MESHFLOW_BIN") or str(ROOT / "target" / "debug" / "meshflow")
    if not Path(b).exists():
        pytest.skip(f"no meshflow binary at {b}: cargo build --bin meshflow, or set MESHFLOW_BIN")
    return b


def read_obj(path) -> tuple[np.ndarray, np.ndarray]:
    """`v x y z` and triangular `f a b c` lines (1-based, `a/t/n` forms) only."""
    vs, fs = [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            vs.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            idx = [i - 1 if i > 0 else len(vs) + i for i in idx]
            for k in range(1, len(idx) - 1):
                fs.append([idx[0], idx[k], idx[k + 1]])
    return np.array(vs, dtype=np.float32), np.array(fs, dtype=np.uint32)


@pytest.fixture(scope="session")
def binary() -> str:
    return meshflow_bin()


@pytest.fixture(scope="session")
def bunny() -> tuple[np.ndarray, np.ndarray]:
    return read_obj(BUNNY)


@pytest.fixture(scope="session")
def cluster(binary, tmp_path_factory):
    """`meshflow up --hosts 2 --listen 127.0.0.1:0`: yields a `Cluster`."""
    data = tmp_path_factory.mktemp("up")
    err = open(data / "up.stderr", "wb")
    env = dict(os.environ)
    for k in ("MESHFLOW_API_TOKEN", "MESHFLOW_CLUSTER_TOKEN", "MESHFLOW_UPLOAD_TOKEN"):
        env.pop(k, None)
    proc = subprocess.Popen(
        [binary, "up", "--hosts", "2", "--listen", "127.0.0.1:0", "--data", str(data / "data")],
        stdout=subprocess.PIPE, stderr=err, text=True, env=env)
    url = token = upload = None
    deadline = time.monotonic() + 60
    lines = []
    while None in (url, token, upload) and time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        if m := re.match(r"engine:\s+(\S+)", line):
            url = m.group(1)
        if m := re.search(r"MESHFLOW_API_TOKEN=(\S+)", line):
            token = m.group(1)
        if m := re.search(r"MESHFLOW_UPLOAD_TOKEN=(\S+)", line):
            upload = m.group(1)
    if None in (url, token, upload):
        proc.kill()
        raise RuntimeError(f"meshflow up printed no engine URL and token: {''.join(lines)}"
                           f"{(data / 'up.stderr').read_text()[-2000:]}")
    engine = meshflow.Engine(url, token=token)
    while time.monotonic() < deadline:
        try:
            if engine.ready().get("hosts_up", 0) >= 2:
                break
        except meshflow.MeshflowError:
            pass
        time.sleep(0.1)
    yield Cluster(url, token, upload, data / "data")
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
    err.close()


@pytest.fixture()
def engine(cluster) -> meshflow.Engine:
    return meshflow.Engine(cluster.url, token=cluster.token)
