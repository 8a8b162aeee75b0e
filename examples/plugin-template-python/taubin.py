"""Taubin smoothing (lambda|mu) in plain Python, the same operations as the built-in
`taubin-smoothing` (plugins/smoothing/src/taubin.rs) and the C++ template: neighbours
ascending, the uniform Laplacian summed in double, each half-step rounded to float32 once
(an ``array('f')`` store), boundary vertices and vertices without neighbours fixed."""

from array import array


def neighbours_of(n, triangles):
    """Per vertex, the distinct in-range vertices sharing a triangle with it, ascending."""
    sets = [set() for _ in range(n)]
    for t in range(0, len(triangles) - 2, 3):
        c = (triangles[t], triangles[t + 1], triangles[t + 2])
        for a in c:
            if a >= n:
                continue
            for b in c:
                if a != b and b < n:
                    sets[a].add(b)
    return [sorted(s) for s in sets]


def boundary_vertices(n, triangles):
    """Vertices on an edge that only one proper triangle (three distinct in-range corners) has."""
    count = {}
    for t in range(0, len(triangles) - 2, 3):
        a, b, c = triangles[t], triangles[t + 1], triangles[t + 2]
        if a == b or b == c or a == c or a >= n or b >= n or c >= n:
            continue
        for u, v in ((a, b), (b, c), (c, a)):
            e = (u, v) if u < v else (v, u)
            count[e] = count.get(e, 0) + 1
    pinned = [False] * n
    for (u, v), k in count.items():
        if k == 1:
            pinned[u] = pinned[v] = True
    return pinned


def smooth(positions, triangles, lam, mu, iterations):
    """`iterations` lambda|mu steps; returns a new ``array('f')``."""
    n = len(positions) // 3
    nb = neighbours_of(n, triangles)
    pinned = boundary_vertices(n, triangles)
    free = [v for v in range(n) if not pinned[v] and nb[v]]
    cur = array("f", positions[:3 * n])
    lap = [0.0] * (3 * n)
    for _ in range(iterations):
        for factor in (lam, mu):
            for v in free:
                sx = sy = sz = 0.0
                for w in nb[v]:
                    i = 3 * w
                    sx += cur[i]
                    sy += cur[i + 1]
                    sz += cur[i + 2]
                k = float(len(nb[v]))
                i = 3 * v
                lap[i] = sx / k - cur[i]
                lap[i + 1] = sy / k - cur[i + 1]
                lap[i + 2] = sz / k - cur[i + 2]
            for v in free:
                i = 3 * v
                cur[i] = cur[i] + factor * lap[i]
                cur[i + 1] = cur[i + 1] + factor * lap[i + 1]
                cur[i + 2] = cur[i + 2] + factor * lap[i + 2]
    return cur
