"""A plugin for test_python_plugin.py, built by the template's Makefile: one filter, offered
whole (`lift-py`) and declared to run in blocks (`lift-in-blocks-py`, `blocks=`)."""

# Service, Locality and Blocks: the exports componentize-py binds.
from meshflow_plugin import Blocks, Integer, Locality, Mesh, Real, Service, filter  # noqa: F401

REMOVED = 0xFFFFFFFF
DZ = Real("dz", 0.01, min=-1.0, max=1.0, doc="How far up.")


@filter("lift-py", "Lifts every vertex off the boundary.", params=[DZ])
@filter("lift-in-blocks-py", "Lifts every vertex off the boundary, in blocks (0: whole).",
        params=[DZ, Integer("block-triangles", 1000, min=0, max=2**32 - 1, doc="Block size.")],
        blocks=lambda params: params["block-triangles"])
def lift_inside(mesh: Mesh, params: dict) -> str:
    """Lifts by `dz` every vertex of a triangle that is on no boundary edge (an edge of one
    triangle), in one move-vertices. In a block, the block's border is a boundary."""
    t = mesh.triangles()
    uses: dict[tuple[int, int], int] = {}
    for i in range(0, len(t), 3):
        if t[i] == REMOVED:
            continue
        for a, b in ((t[i], t[i + 1]), (t[i + 1], t[i + 2]), (t[i + 2], t[i])):
            edge = (min(a, b), max(a, b))
            uses[edge] = uses.get(edge, 0) + 1
    boundary = {v for edge, n in uses.items() if n == 1 for v in edge}
    ids = sorted({v for edge in uses for v in edge} - boundary)
    p, dz = mesh.positions(), params["dz"]
    xyz = [c for v in ids for c in (p[3 * v], p[3 * v + 1], p[3 * v + 2] + dz)]
    mesh.move_vertices(ids, xyz)
    return f"lifted {len(ids)} of {mesh.vertex_count()} vertices"
