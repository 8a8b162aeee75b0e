"""The engine's HTTP API (docs/api.md) from Python."""

from __future__ import annotations

import html
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import requests

from . import meshio
from .errors import HashMismatch, MeshflowError, RunFailed
from .workflow import workflow_dict

FINAL = ("completed", "failed", "cancelled", "interrupted")
FORMATS = ("ply", "obj", "off", "stl", "mfm", "raw")


def _is_url(s) -> bool:
    return isinstance(s, str) and s.startswith(("http://", "https://"))


class Engine:
    """A meshflow engine, e.g. ``Engine("http://127.0.0.1:7000")``.

    ``token``: the API token (default ``MESHFLOW_API_TOKEN``); ``ca_file``: a PEM file of
    the CA to trust for https (default ``MESHFLOW_CA_FILE``, then the system's roots).
    """

    def __init__(self, url: str, token: str | None = None, ca_file: str | None = None,
                 timeout: float = 30.0):
        self.url = url.rstrip("/")
        self.token = token if token is not None else os.environ.get("MESHFLOW_API_TOKEN")
        ca_file = ca_file if ca_file is not None else os.environ.get("MESHFLOW_CA_FILE")
        self.timeout = timeout
        self.session = requests.Session()
        if self.token:
            self.session.headers["Authorization"] = f"Bearer {self.token}"
        self.session.headers["User-Agent"] = "meshflow-python/0.1.0"
        if ca_file:
            self.session.verify = ca_file

    def __repr__(self):
        return f"Engine({self.url!r})"

    # ---- plumbing ---------------------------------------------------------------------
    def _request(self, method: str, path: str, *, json_body: Any = None, data=None,
                 params=None, stream=False, timeout=None, headers=None) -> requests.Response:
        h = dict(headers or {})
        if json_body is not None:
            data = json.dumps(json_body).encode()
            h["Content-Type"] = "application/json"
        try:
            r = self.session.request(method, self.url + path, data=data, params=params,
                                     stream=stream, timeout=timeout or self.timeout, headers=h)
        except requests.ConnectionError as e:
            raise MeshflowError("unreachable", f"{method} {self.url}{path}: {e}") from e
        except requests.Timeout as e:
            raise MeshflowError("timeout", f"{method} {self.url}{path}: {e}") from e
        if r.status_code >= 400:
            raise _error_of(r)
        return r

    def _json(self, method: str, path: str, **kw) -> Any:
        return self._request(method, path, **kw).json()

    # ---- catalogue and state ----------------------------------------------------------
    def health(self) -> dict:
        return self._json("GET", "/health")

    def ready(self) -> dict:
        return self._json("GET", "/ready")

    def me(self) -> dict:
        return self._json("GET", "/me")

    def services(self) -> list[dict]:
        """Every service on offer: its description (name, kind, doc, params with types,
        defaults and ranges), the hosts offering it and the plugin digests."""
        return self._json("GET", "/services")

    def hosts(self) -> list[dict]:
        return self._json("GET", "/hosts")

    def runs(self) -> list["Run"]:
        """The runs the engine keeps (yours; an admin's: everyone's), oldest first."""
        return [Run(self, r["id"]) for r in self._json("GET", "/runs")]

    def get_run(self, run_id: str) -> "Run":
        run = Run(self, run_id)
        run.refresh()
        return run

    def validate(self, workflow) -> None:
        """Raises :class:`MeshflowError` (``invalid-workflow``) for a workflow the engine refuses."""
        self._json("POST", "/workflows/validate", json_body={"workflow": workflow_dict(workflow)})

    # ---- inputs -----------------------------------------------------------------------
    def upload(self, mesh, name: str | None = None) -> str:
        """Uploads a mesh (file path, ``(vertices, faces)`` arrays, a ``trimesh.Trimesh`` or
        bytes) with ``POST /inputs`` and returns its URL; a URL is returned as it is."""
        if _is_url(mesh):
            return mesh
        if isinstance(mesh, (str, Path)):
            path = Path(mesh)
            with open(path, "rb") as f:
                answer = self._json("POST", "/inputs", params={"name": name or path.name}, data=f,
                                    timeout=max(self.timeout, 600))
            return answer["url"]
        if isinstance(mesh, (bytes, bytearray, memoryview)):
            data = bytes(mesh)
        else:
            vertices, faces = _arrays_of(mesh)
            data = meshio.ply_bytes(vertices, faces)
            name = name or "mesh.ply"
        answer = self._json("POST", "/inputs", params={"name": name or "mesh.ply"}, data=data,
                            timeout=max(self.timeout, 600))
        return answer["url"]

    # ---- plugins ----------------------------------------------------------------------
    def upload_plugin(self, plugin, host: str, upload_token: str | None = None,
                      replace: bool = False, timeout: float = 900.0) -> dict:
        """Publishes a plugin component (a ``.wasm`` path or its bytes) on the registered
        host ``host`` through the engine (``POST /plugins?host=``, as ``meshflow plugin
        upload --engine``), which offers its services at once. ``upload_token``: the host's
        (default ``MESHFLOW_UPLOAD_TOKEN``). Returns the host's answer: ``digest``,
        ``services``, ``new``, ``replaced``, ``present``. The host compiles the component
        before answering (a Python one: tens of seconds the first time), hence ``timeout``."""
        token = upload_token if upload_token is not None else os.environ.get("MESHFLOW_UPLOAD_TOKEN")
        if not token:
            raise MeshflowError("no-upload-token",
                                "give the host's upload token: upload_token=… or MESHFLOW_UPLOAD_TOKEN")
        data = bytes(plugin) if isinstance(plugin, (bytes, bytearray, memoryview)) \
            else Path(plugin).read_bytes()
        params = {"host": host.rstrip("/"), "replace": "true" if replace else "false"}
        return self._json("POST", "/plugins", params=params, data=data, timeout=timeout,
                          headers={"X-Upload-Token": token,
                                   "Content-Type": "application/wasm"})

    # ---- runs -------------------------------------------------------------------------
    def run(self, workflow, mesh=None, name: str | None = None) -> "Run":
        """Submits ``workflow`` on ``mesh`` (a path, a URL, ``(vertices, faces)`` arrays or
        a ``trimesh.Trimesh``; ``None`` when the workflow names its ``input``) and returns
        the :class:`Run` at once; ``run.wait()`` follows it."""
        body: dict = {"workflow": workflow_dict(workflow)}
        if mesh is not None:
            body["input"] = self.upload(mesh, name)
        answer = self._json("POST", "/runs", json_body=body)
        return Run(self, answer["id"], answer)

    def batch(self, workflow, meshes: Iterable, concurrency: int = 4, progress: bool = False,
              poll: float = 0.25) -> list[dict]:
        """Runs one workflow over many meshes (each as in :meth:`run`), waits, and returns the
        batch's summary rows (name, status, error, counts in and out, result_hash,
        total_seconds, bytes_moved, checks), one per mesh in order."""
        names = []
        inputs = []
        for i, m in enumerate(meshes):
            if isinstance(m, (str, Path)) and not _is_url(m):
                names.append(None)
            else:
                names.append(f"mesh-{i}.ply")
            inputs.append(self.upload(m, names[-1]))
        body = {"workflow": workflow_dict(workflow), "inputs": inputs, "concurrency": concurrency}
        batch = self._json("POST", "/batches", json_body=body)
        bar = _Progress(progress, total=len(inputs), unit="mesh")
        try:
            while batch.get("status") != "completed":
                time.sleep(poll)
                batch = self._json("GET", f"/batches/{batch['id']}")
                done = sum(1 for r in batch.get("rows", []) if r.get("status") in FINAL)
                bar.update(done, f"batch {batch['id']}")
        finally:
            bar.close()
        self.last_batch = batch
        return batch.get("rows", [])


class Run:
    """A run on the engine. ``record`` is its last fetched run record (docs/api.md),
    ``steps`` the record's steps; in a notebook it shows as a table of its steps."""

    def __init__(self, engine: Engine, run_id: str, record: dict | None = None):
        self.engine = engine
        self.id = run_id
        self._record = dict(record or {"id": run_id, "status": "queued"})

    def __repr__(self):
        return f"<Run {self.id} {self.status}, {len(self.steps)} steps>"

    # ---- state ------------------------------------------------------------------------
    def refresh(self) -> dict:
        self._record = self.engine._json("GET", f"/runs/{self.id}")
        return self._record

    @property
    def record(self) -> dict:
        """The run record; fetched again until it has settled (ended, and a completed run's
        result packed where it is held)."""
        if not self._settled() or "steps" not in self._record:
            self.refresh()
        return self._record

    def _settled(self) -> bool:
        status = self._record.get("status")
        return status in FINAL and (status != "completed" or "settled_ms" in self._record)

    @property
    def status(self) -> str:
        return self._record.get("status", "queued")

    @property
    def steps(self) -> list[dict]:
        return self.record.get("steps") or []

    @property
    def done(self) -> bool:
        return self.status in FINAL

    def wait(self, progress: bool = True, timeout: float | None = None) -> "Run":
        """Follows the run until it ends (server-sent events, polling when they fail) and
        returns it; ``progress`` shows each step as it finishes (tqdm when installed, else
        a line per step on stderr). Raises ``TimeoutError`` after ``timeout`` seconds."""
        deadline = None if timeout is None else time.monotonic() + timeout
        bar = _Progress(progress, total=None, unit="step")
        try:
            if not self.done:
                try:
                    self._follow_events(bar, deadline)
                except (requests.RequestException, MeshflowError, ValueError):
                    pass
            while not self.done:
                if deadline is not None and time.monotonic() > deadline:
                    raise TimeoutError(f"run {self.id} still {self.status} after {timeout} s")
                time.sleep(0.2)
                self.refresh()
                bar.show_steps(self._record)
            bar.show_steps(self._record)
        finally:
            bar.close()
        return self

    def _follow_events(self, bar: "_Progress", deadline: float | None) -> None:
        r = self.engine._request("GET", f"/runs/{self.id}/events", stream=True,
                                 timeout=(10, 60), headers={"Accept": "text/event-stream"})
        with r:
            event, data = None, []
            for line in r.iter_lines(decode_unicode=True):
                if deadline is not None and time.monotonic() > deadline:
                    raise TimeoutError(f"run {self.id} still {self.status} after {deadline} s")
                if line is None:
                    continue
                if line == "":
                    if data and event in (None, "record"):
                        self._record = json.loads("\n".join(data))
                        bar.show_steps(self._record)
                        if self.done:
                            return
                    event, data = None, []
                elif line.startswith(":"):
                    continue
                elif line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data.append(line[5:].lstrip(" ") if line[5:6] == " " else line[5:])
        self.refresh()

    # ---- results ----------------------------------------------------------------------
    def _need_result(self) -> dict:
        rec = self.record
        if rec.get("status") != "completed":
            if rec.get("status") not in FINAL:
                self.wait(progress=False)
                rec = self._record
            if rec.get("status") != "completed":
                raise RunFailed(self.id, rec.get("status"), rec.get("error"))
        return rec

    def result(self, verify: bool | None = None, attributes: bool = False):
        """The final mesh as ``(vertices (V, 3) float32, faces (T, 3) uint32)``, waiting for
        the run first; with ``attributes=True`` also what it carries beyond them (colours,
        normals, quality, …; see :func:`meshflow.raw_attributes`) as a third item.
        Downloaded as ``?format=raw`` (the host writing it checked its content
        hash, and the engine checks it again). With the ``blake3`` package the client
        checks it a third time against the record's ``result.hash`` (``verify=None``: when
        blake3 is installed; ``True``: always, ``False``: never)."""
        rec = self._need_result()
        data = self.engine._request("GET", f"/runs/{self.id}/result", params={"format": "raw"},
                                    timeout=(10, 600)).content
        if verify is not False:
            got = meshio.content_hash_of_raw(data)
            if got is None and verify:
                raise ImportError("verify=True needs the blake3 package: pip install meshflow[verify]")
            expected = (rec.get("result") or {}).get("hash")
            if got is not None and expected and got != expected:
                raise HashMismatch(expected, got)
        if attributes:
            return (*meshio.parse_raw(data), meshio.raw_attributes(data))
        return meshio.parse_raw(data)

    def result_trimesh(self, verify: bool | None = None):
        """The final mesh as a ``trimesh.Trimesh`` (needs trimesh)."""
        import trimesh  # type: ignore

        v, f = self.result(verify)
        return trimesh.Trimesh(vertices=v, faces=f, process=False)

    @property
    def result_hash(self) -> str | None:
        return (self.record.get("result") or {}).get("hash")

    def download(self, path, format: str | None = None, step: int | None = None) -> Path:
        """Writes the result (or a filter step's output, ``step=index``) to ``path`` as
        ``format`` (ply, obj, off, stl, mfm or raw; default: from the file's suffix, else ply)."""
        path = Path(path)
        fmt = format or (path.suffix[1:].lower() if path.suffix[1:].lower() in FORMATS else "ply")
        if fmt not in FORMATS:
            raise ValueError(f"format must be one of {', '.join(FORMATS)}, not {fmt!r}")
        self._need_result() if step is None else None
        route = f"/runs/{self.id}/result" if step is None else f"/runs/{self.id}/steps/{step}/output"
        r = self.engine._request("GET", route, params={"format": fmt}, stream=True, timeout=(10, 600))
        tmp = path.with_name(path.name + ".part")
        with r, open(tmp, "wb") as out:
            for chunk in r.iter_content(1 << 20):
                out.write(chunk)
        tmp.replace(path)
        return path

    def step_output(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """A filter step's output mesh as arrays (while its host still holds it)."""
        data = self.engine._request("GET", f"/runs/{self.id}/steps/{index}/output",
                                    params={"format": "raw"}, timeout=(10, 600)).content
        return meshio.parse_raw(data)

    # ---- control ----------------------------------------------------------------------
    def cancel(self) -> "Run":
        """Cancels the run (it reads ``cancelled`` at once); raises ``finished`` if it had ended."""
        answer = self.engine._json("POST", f"/runs/{self.id}/cancel")
        self._record.update({k: v for k, v in answer.items() if k in ("id", "status")})
        self.refresh()
        return self

    def rerun(self, input: str | None = None, unpinned: bool = False) -> "Run":
        """The same workflow again, every task pinned to the plugin and parameters this run
        used (``unpinned``: today's plugins), on the recorded input or ``input`` (a URL)."""
        body: dict = {"unpinned": unpinned}
        if input is not None:
            body["input"] = input
        answer = self.engine._json("POST", f"/runs/{self.id}/rerun", json_body=body)
        return Run(self.engine, answer["id"], answer)

    def comparison(self) -> dict:
        """For a finished re-run: ``{"identical", "divergence", …}`` against the original."""
        return self.engine._json("GET", f"/runs/{self.id}/comparison")

    def workflow(self) -> dict:
        return self.engine._json("GET", f"/runs/{self.id}/workflow")

    # ---- notebooks --------------------------------------------------------------------
    def _repr_html_(self) -> str:
        rec = self._record
        e = html.escape
        rows = []
        for s in rec.get("steps") or []:
            what = s.get("value") if s.get("kind") == "check" else (s.get("output_hash") or "")[:12]
            if s.get("condition") is not None:
                what = f"{what} → {s.get('condition')}"
            ms = s.get("compute_ms")
            rows.append(
                "<tr>" + "".join(f"<td>{e(str(x))}</td>" for x in (
                    s.get("index"), s.get("path"), s.get("service"), s.get("kind"),
                    s.get("host", ""), "" if ms is None else f"{ms:.1f}",
                    s.get("vertices", ""), s.get("triangles", ""), what)) + "</tr>")
        head = "".join(f"<th>{h}</th>" for h in (
            "#", "path", "service", "kind", "host", "compute ms", "vertices", "triangles", "result"))
        res = rec.get("result") or {}
        summary = f"run <code>{e(self.id)}</code>: <b>{e(str(rec.get('status')))}</b>"
        if rec.get("total_ms") is not None:
            summary += f" in {rec['total_ms'] / 1000:.2f} s"
        if res.get("hash"):
            summary += f", result {res.get('vertices')} vertices, {res.get('triangles')} triangles, hash <code>{e(res['hash'][:16])}…</code>"
        if rec.get("error"):
            summary += f"<br><span style='color:#b00'>{e(str(rec['error']))}</span>"
        return (f"<div><p>{summary}</p><table><thead><tr>{head}</tr></thead>"
                f"<tbody>{''.join(rows)}</tbody></table></div>")


# ---- helpers ------------------------------------------------------------------------------
def _error_of(r: requests.Response) -> MeshflowError:
    try:
        body = r.json()
        err = body["error"]
        return MeshflowError(err.get("code", f"http-{r.status_code}"), err.get("message", ""), r.status_code)
    except Exception:
        text = r.text[:500] if r.text else r.reason
        return MeshflowError(f"http-{r.status_code}", text, r.status_code)


def _arrays_of(mesh) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return meshio.as_arrays(*mesh)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):  # trimesh.Trimesh and friends
        return meshio.as_arrays(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    raise TypeError("a mesh is a path, a URL, (vertices, faces) arrays or a trimesh.Trimesh, "
                    f"not {type(mesh).__name__}")


class _Progress:
    """tqdm when installed, else one line per finished step on stderr; nothing when off."""

    def __init__(self, enabled: bool, total: int | None, unit: str):
        self.enabled, self.unit, self.shown, self.bar = enabled, unit, 0, None
        if enabled:
            try:
                from tqdm.auto import tqdm  # type: ignore

                self.bar = tqdm(total=total, unit=unit)
            except ImportError:
                self.bar = None

    def update(self, n: int, desc: str) -> None:
        if not self.enabled or n <= self.shown:
            return
        if self.bar is not None:
            self.bar.set_description(desc)
            self.bar.update(n - self.shown)
        else:
            print(f"{desc}: {n} {self.unit}(s) done", file=sys.stderr)
        self.shown = n

    def show_steps(self, rec: dict) -> None:
        if not self.enabled:
            return
        steps = rec.get("steps") or []
        done = [s for s in steps if s.get("finished_ms") is not None]
        for s in done[self.shown:]:
            ms = s.get("compute_ms")
            what = f"= {s.get('value')}" if s.get("kind") == "check" else f"{s.get('vertices')} v, {s.get('triangles')} t"
            line = f"{s.get('path')} {s.get('service')} {what}" + ("" if ms is None else f" ({ms:.1f} ms)")
            if self.bar is not None:
                self.bar.set_description(f"{s.get('service')}")
                self.bar.update(1)
            else:
                print(line, file=sys.stderr)
        self.shown = max(self.shown, len(done))
        if rec.get("status") in FINAL and not getattr(self, "_ended", False):
            self._ended = True
            msg = f"run {rec.get('id')} {rec.get('status')}"
            if rec.get("error"):
                msg += f": {rec['error']}"
            if self.bar is not None:
                self.bar.set_description(msg)
            else:
                print(msg, file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
