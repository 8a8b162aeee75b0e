"""A meshflow plugin in Python: Taubin smoothing (`taubin-smoothing-py`), and a check.

Build: `make` (a venv with componentize-py, then `py.wasm`). Run:
`meshflow apply --plugin py.wasm taubin-smoothing-py bunny.obj -o out.ply`.
"""

# Service, Locality and Blocks: the exports componentize-py binds.
from meshflow_plugin import Blocks, Integer, Locality, Mesh, Real, Service, check, filter  # noqa: F401

import taubin


@filter(
    "taubin-smoothing-py",
    "Smooths without shrinking (Taubin's lambda|mu), written in Python. Boundary vertices stay.",
    params=[
        Real("lambda", 0.5, min=1e-6, max=1.0, doc="Shrinking step, towards the neighbours' mean."),
        Real("mu", -0.53, min=-1.0, max=-1e-6, doc="Inflating step (negative)."),
        Integer("iterations", 10, min=1, max=1000, doc="lambda|mu steps."),
    ],
    # Each lambda|mu step reads one ring further: a host may run it on partitions of a
    # mesh too large for one sandbox.
    reach=lambda params: 2 * params["iterations"],
)
def taubin_smoothing(mesh: Mesh, params: dict) -> str:
    # Read both arrays once, smooth, write every position back in one recorded edit.
    smoothed = taubin.smooth(mesh.positions(), mesh.triangles(), params["lambda"], params["mu"],
                             params["iterations"])
    mesh.set_positions(smoothed)
    return f"{params['iterations']} Taubin iteration(s) over {mesh.vertex_count()} vertices (Python)"


@check("mean-valence-py", "Mean number of neighbours per vertex that has any.", result="real")
def mean_valence(mesh: Mesh, params: dict) -> float:
    p, t = mesh.positions(), mesh.triangles()
    nb = taubin.neighbours_of(len(p) // 3, t)
    used = [len(x) for x in nb if x]
    return sum(used) / len(used) if used else 0.0
