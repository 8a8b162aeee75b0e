"""The template's services in plain CPython, on the SDK's NativeMesh: `make test`."""

import app  # noqa: F401 (declares the services)
from meshflow_plugin import NativeMesh, run_native


def test_boundary_stays_and_the_apex_follows_lambda_then_mu():
    # A fan of four triangles around vertex 4, lifted, plus an unreferenced vertex 5.
    positions = [0, 0, 0, 2, 0, 0, 2, 2, 0, 0, 2, 0, 1, 1, 1, 5, 5, 5]
    triangles = [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4]
    mesh = NativeMesh(positions, triangles)
    _, report = run_native("taubin-smoothing-py", mesh, iterations=3)
    p = mesh.positions()
    assert list(p[:12]) == positions[:12] and list(p[15:]) == positions[15:]
    assert "3 Taubin" in report and mesh.edits == 1
    import struct

    f32 = lambda x: struct.unpack("f", struct.pack("f", x))[0]  # noqa: E731
    z = 1.0
    for _ in range(3):
        z = f32(z + 0.5 * -z)
        z = f32(z + -0.53 * -z)
    assert p[14] == z and list(p[12:14]) == [1.0, 1.0]


def test_mean_valence():
    mesh = NativeMesh([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2])
    assert run_native("mean-valence-py", mesh) == (2.0, "")
