"""meshflow: run triangle-mesh workflows on a meshflow engine from Python.

    import meshflow
    engine = meshflow.Engine("http://127.0.0.1:7000")        # token: MESHFLOW_API_TOKEN
    run = engine.run("examples/workflows/repair.json", (vertices, faces))
    vertices, faces = run.wait().result()

The client runs nothing itself: every step runs on the engine's hosts, in their sandbox.
"""

from .client import Engine, Run
from .errors import HashMismatch, MeshflowError, RunFailed
from .meshio import content_hash, parse_raw, ply_bytes, raw_attributes, raw_bytes
from .workflow import Check, Condition, Workflow, check, if_, run, while_

__version__ = "0.1.0"
__all__ = [
    "Engine", "Run", "MeshflowError", "RunFailed", "HashMismatch", "Workflow", "check", "run",
    "if_", "while_", "Check", "Condition", "content_hash", "parse_raw", "ply_bytes", "raw_attributes", "raw_bytes",
]
