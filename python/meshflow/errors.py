"""Exceptions carrying the engine's error code and message."""

from __future__ import annotations


class MeshflowError(Exception):
    """An error answer of the engine: ``{"error": {"code", "message"}}``.

    ``code`` is the engine's error code (``invalid-workflow``, ``no-input``, ``not-found``,
    ``unauthorized``, …; see docs/api.md), ``message`` its message and ``status`` the HTTP
    status (``None`` for errors raised by the client itself).
    """

    def __init__(self, code: str, message: str, status: int | None = None):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message
        self.status = status


class RunFailed(MeshflowError):
    """A run ended ``failed``, ``cancelled`` or ``interrupted`` when a result was asked for."""

    def __init__(self, run_id: str, status: str, message: str | None):
        super().__init__(f"run-{status}", f"run {run_id} ended {status}: {message or '(no message)'}")
        self.run_id = run_id
        self.run_status = status


class HashMismatch(MeshflowError):
    """A downloaded mesh whose BLAKE3 content hash is not the run record's."""

    def __init__(self, expected: str, got: str):
        super().__init__("hash-mismatch", f"downloaded mesh hashes to {got}, the record says {expected}")
        self.expected = expected
        self.got = got
