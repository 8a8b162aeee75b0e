"""meshflow's plugin SDK for Python: the twin of the Rust SDK's ``Mesh`` and ``export_plugin!``.

A plugin is a module that describes its services in code, one decorator per service, and
re-exports :class:`Service`, the class componentize-py binds to the WIT's ``service``
interface::

    from array import array
    from meshflow_plugin import Mesh, Real, Service, filter  # Service: the export

    @filter("lift", "Moves every vertex up by `dz`.",
            params=[Real("dz", 1.0, min=-1e3, max=1e3, doc="Distance along z.")])
    def lift(mesh: Mesh, params: dict) -> str:
        p = mesh.positions()                 # array('f'): x y z per vertex slot
        for i in range(2, len(p), 3):
            p[i] += params["dz"]
        mesh.set_positions(p)                # one recorded edit
        return f"lifted {mesh.vertex_count()} vertices"

Build it with ``componentize-py -d wit -w block-plugin componentize app -o plugin.wasm`` (see
examples/plugin-template-python/; the module also re-exports :class:`Locality` and
:class:`Blocks`, or use ``-w plugin`` for a plugin that declares neither ``reach`` nor
``blocks``). Inside the sandbox there is no numpy, no files, no
network, a frozen clock and seeded randomness: plain Python and the standard library.

The host checks parameters against the description before ``run`` (names, types, ranges,
choices) and fills in defaults, so a service gets every declared parameter. An exception a
service raises becomes the run's error string (``MeshError`` for a refused edit keeps the
WIT's ``edit-error-kind``); nothing half-done escapes: the host keeps only runs that return.
"""

from __future__ import annotations

import math
from array import array
from typing import Any, Callable, NamedTuple, Sequence

__all__ = [
    "Mesh", "MeshError", "ServiceError", "Boolean", "Integer", "Real", "Text", "filter", "check",
    "services", "Service", "Locality", "Blocks", "NativeMesh", "bounds_of", "run_native", "AttributeInfo",
    "blend_new_vertex_attributes",
]


# ---- errors ---------------------------------------------------------------------------------
class MeshError(Exception):
    """An edit the host refused (the WIT's ``edit-error``); ``kind`` is its kind as written
    in the WIT (``invalid-vertex``, ``not-applicable``, ``read-only``, …). The mesh is
    unchanged by a refused edit."""

    def __init__(self, kind: str, message: str):
        super().__init__(f"{kind}: {message}")
        self.kind, self.message = kind, message


class ServiceError(Exception):
    """Raise to fail a run with this message (any exception does; this one is reported
    without its type name)."""


# ---- parameters -----------------------------------------------------------------------------
class _Param:
    ty = ""

    def __init__(self, name: str, default, *, min: float | None = None, max: float | None = None,
                 doc: str = "", choices: Sequence[str] = ()):
        self.name, self.default, self.min, self.max = name, default, min, max
        self.doc, self.choices = doc, list(choices)

    def _info(self):
        from wit_world.imports import types as t

        return t.ParamInfo(name=self.name, doc=self.doc, ty=_VALUE_TYPES[self.ty](),
                           default=_to_value(self.ty, self.default),
                           min=None if self.min is None else float(self.min),
                           max=None if self.max is None else float(self.max),
                           choices=list(self.choices))


class Boolean(_Param):
    """A ``boolean`` parameter: ``Boolean("keep-boundary", True, doc=...)``."""
    ty = "boolean"


class Integer(_Param):
    """An ``integer`` parameter with an inclusive range: ``Integer("iterations", 10, min=1, max=1000)``."""
    ty = "integer"


class Real(_Param):
    """A ``real`` parameter with an inclusive range: ``Real("lambda", 0.5, min=1e-6, max=1.0)``."""
    ty = "real"


class Text(_Param):
    """A ``text`` parameter; ``choices`` lists the accepted words (empty: any text)."""
    ty = "text"


def _vt(name):
    def make():
        from wit_world.imports import types as t

        return getattr(t.ValueType, name.upper())
    return make


_VALUE_TYPES = {k: _vt(k) for k in ("boolean", "integer", "real", "text")}


def _to_value(ty: str, v):
    from wit_world.imports import types as t

    if ty == "boolean":
        return t.Value_Boolean(bool(v))
    if ty == "integer":
        return t.Value_Integer(int(v))
    if ty == "real":
        return t.Value_Real(float(v))
    if ty == "text":
        return t.Value_Text(str(v))
    raise ValueError(f"unknown value type {ty!r}")


# ---- services -------------------------------------------------------------------------------
class _Svc:
    def __init__(self, name, kind, doc, params, fn, result, reach=None, blocks=None):
        self.name, self.kind, self.doc, self.params, self.fn, self.result = name, kind, doc, list(params), fn, result
        self.reach, self.blocks = reach, blocks

    def _info(self):
        from wit_world.imports import types as t

        kind = t.ServiceKind.FILTER if self.kind == "filter" else t.ServiceKind.CHECK
        return t.ServiceInfo(name=self.name, kind=kind, doc=self.doc,
                             params=[p._info() for p in self.params],
                             result_type=None if self.result is None else _VALUE_TYPES[self.result]())


_SERVICES: dict[str, _Svc] = {}


def _register(svc: _Svc) -> None:
    if svc.name in _SERVICES:
        raise ValueError(f"service {svc.name!r} is declared twice")
    _SERVICES[svc.name] = svc


def filter(name: str, doc: str, params: Sequence[_Param] = (),
           reach: int | Callable[[dict], int] | None = None,
           blocks: int | Callable[[dict], int | None] | None = None) -> Callable:
    """Declares a filter: ``fn(mesh, params) -> str`` edits ``mesh`` and returns a short
    report (``None`` reads as an empty report).

    ``reach`` declares the filter local (WIT ``locality``): it only moves vertices, and a
    vertex's new position depends only on the mesh within that many rings of it (an ``int``,
    or ``fn(params) -> int``), neighbours visited in ascending id order. A host may then run
    it on partitions of a mesh larger than one sandbox, and checks that the result is the
    same bit for bit. Needs the plugin built for world ``local-plugin`` or ``block-plugin``,
    exporting :class:`Locality`. ``None``: always the whole mesh.

    ``blocks`` (an ``int``, or ``fn(params) -> int | None``) declares that on a mesh of more
    than that many triangles the filter's result is, by definition, its result on each block
    of about that many triangles run as a mesh of its own, the vertices blocks share kept
    where they are (WIT ``blocks``, as the Rust SDK's ``Service::blocks``). Every host cuts
    the same blocks, so results agree across hosts, but not with a whole-mesh run. A block's
    border is its boundary: a filter that may move or remove boundary vertices with these
    parameters gives ``None``. A host refuses blocks of fewer than 1000 triangles, and edits
    it cannot rename into the mesh (``set_positions``, ``transform``, ``clear``, component and
    attribute edits). Needs world ``block-plugin``, exporting :class:`Blocks` (and
    :class:`Locality`). ``None`` or ``0``: always the whole mesh."""
    def deco(fn):
        _register(_Svc(name, "filter", doc, params, fn, None, reach, blocks))
        return fn
    return deco


def check(name: str, doc: str, result: str, params: Sequence[_Param] = ()) -> Callable:
    """Declares a check of ``result`` type ``boolean | integer | real | text``:
    ``fn(mesh, params)`` returns the value, or ``(value, report)``. Checks cannot edit."""
    if result not in _VALUE_TYPES:
        raise ValueError(f"result must be boolean, integer, real or text, not {result!r}")

    def deco(fn):
        _register(_Svc(name, "check", doc, params, fn, result))
        return fn
    return deco


def services() -> list[_Svc]:
    """The services declared so far, in declaration order."""
    return list(_SERVICES.values())


def _call(svc: _Svc, mesh, params: dict):
    """Runs a service; returns ``(value or None, report)``."""
    out = svc.fn(mesh, params)
    if svc.kind == "filter":
        return None, "" if out is None else str(out)
    value, report = out if isinstance(out, tuple) else (out, "")
    return value, str(report)


class Service:
    """The export componentize-py binds to ``service`` (``describe`` and ``run``); a plugin
    module makes it visible with ``from meshflow_plugin import Service``."""

    def describe(self):
        return [s._info() for s in _SERVICES.values()]

    def run(self, name, target, params):
        from componentize_py_types import Err
        from wit_world.imports import types as t

        svc = _SERVICES.get(name)
        if svc is None:
            raise Err(f"unknown service {name!r}; this plugin offers {', '.join(_SERVICES)}")
        values = {p.name: p.value.value for p in params}
        try:
            value, report = _call(svc, Mesh(target), values)
            return t.Outcome(value=None if value is None else _to_value(svc.result, value), report=report)
        except Err:
            raise
        except ServiceError as e:
            raise Err(f"{name}: {e}")
        except MeshError as e:
            raise Err(f"{name}: {e}")
        except Exception as e:  # any other failure: the run's error, with its type
            raise Err(f"{name}: {type(e).__name__}: {e}")


def _declared(name: str, params, declaration: str) -> int | None:
    """A filter's ``reach`` or ``blocks`` with these parameters (the WIT's ``option<u32>``):
    ``None`` for a service that declared none, an unknown one, or anything but a count a u32
    holds (the host then runs it whole)."""
    svc = _SERVICES.get(name)
    given = None if svc is None else getattr(svc, declaration)
    if callable(given):
        given = given({p.name: p.value.value for p in params})
    return given if isinstance(given, int) and 0 <= given < 2**32 else None


class Locality:
    """The export componentize-py binds to ``locality`` in worlds ``local-plugin`` and
    ``block-plugin``: each filter's ``reach`` (see :func:`filter`). A plugin built for such a
    world makes it visible with ``from meshflow_plugin import Locality``."""

    def reach(self, name, params):
        return _declared(name, params, "reach")


class Blocks:
    """The export componentize-py binds to ``blocks`` in world ``block-plugin``: each
    filter's ``blocks`` (see :func:`filter`). A plugin built for that world makes it visible
    with ``from meshflow_plugin import Blocks``."""

    def block_triangles(self, name, params):
        # Blocks of 0 triangles: none, the filter runs whole.
        return _declared(name, params, "blocks") or None


# ---- the mesh -------------------------------------------------------------------------------
def _edit(call, *args):
    from componentize_py_types import Err

    try:
        return call(*args)
    except Err as e:
        err = e.value
        kind = getattr(getattr(err, "kind", None), "name", "invalid-argument").lower().replace("_", "-")
        raise MeshError(kind, getattr(err, "message", str(err))) from None


def _list(a):
    return a.tolist() if isinstance(a, array) else list(a)


# ---- attributes -----------------------------------------------------------------------------
# The WIT's number types and the `array` type codes that hold them exactly.
_TYPECODES = {"u8": "B", "s32": "i", "u32": "I", "f32": "f", "f64": "d"}
_NUMBER_TYPES = {code: ty for ty, code in _TYPECODES.items()}


class AttributeInfo(NamedTuple):
    """One attribute as :meth:`Mesh.attributes` lists it: ``domain`` is ``vertex``,
    ``face`` or ``corner``; ``number_type`` one of ``u8 s32 u32 f32 f64``."""
    domain: str
    name: str
    components: int
    number_type: str


def _wit_name(member) -> str:
    return getattr(member, "name", str(member)).lower().replace("_", "-")


def _domain(domain: str):
    from wit_world.imports import mesh as m

    return getattr(m.AttributeDomain, domain.upper())


def _values_to_array(values) -> array:
    ty = type(values).__name__.rsplit("_", 1)[-1].lower()
    return array(_TYPECODES[ty], values.value)


def _values_from_array(values: array):
    from wit_world.imports import mesh as m

    ty = _NUMBER_TYPES[values.typecode]
    payload = bytes(values) if ty == "u8" else values.tolist()
    return getattr(m, f"AttributeValues_{ty.upper()}")(payload)


def _round(ty: str, x: float) -> float:
    """As the host rounds an interpolated value: integers to the nearest (ties away from
    zero) within the type's range; floats kept (``array('f')`` rounds to f32 as it stores)."""
    if ty in ("f32", "f64"):
        return x
    lo, hi = {"u8": (0, 255), "s32": (-2**31, 2**31 - 1), "u32": (0, 2**32 - 1)}[ty]
    whole = math.floor(abs(x))
    r = (whole + (abs(x) - whole >= 0.5)) * (1 if x >= 0 else -1)
    return min(max(r, lo), hi)


def blend_new_vertex_attributes(mesh: "Mesh", blends) -> int:
    """Gives vertices made with ``add_vertices`` every vertex attribute (normals aside: the
    host recomputes them) blended from the vertices they came from. ``blends`` is a sequence
    of ``(vertex, [(parent, weight), ...])``; weights must be finite, not negative, and sum
    above zero (they are divided by their sum); a parent may be a vertex listed earlier.
    One read and one ``set_attribute`` per vertex attribute; returns how many were written.
    The same rule, in the same order, as the Rust SDK's helper."""
    blends = [(int(v), [(int(p), float(w)) for p, w in parents]) for v, parents in blends]
    if not blends:
        return 0
    for v, parents in blends:
        total = sum(w for _, w in parents)
        if any(not (w >= 0.0 and w != float("inf")) for _, w in parents) or not 0.0 < total < float("inf"):
            raise ServiceError(f"blend: vertex {v}'s weights must be finite, not negative, and sum above 0")
    ids = [v for v, _ in blends]
    written = 0
    for info in mesh.attributes():
        if info.domain != "vertex" or info.name == "normal":
            continue
        values = mesh.read_attribute("vertex", info.name)
        if values is None:
            continue
        per = info.components
        out = array(values.typecode)
        for v, parents in blends:
            total = sum(w for _, w in parents)
            for k in range(per):
                x = sum(w / total * values[per * p + k] for p, w in parents)
                values[per * v + k] = _round(info.number_type, x)
                out.append(values[per * v + k])
        mesh.set_attribute("vertex", info.name, per, out, ids=ids)
        written += 1
    return written


def bounds_of(positions):
    """``((min x, y, z), (max x, y, z))`` over ``x y z`` triples, NaNs skipped, as the host
    and the Rust SDK compute it; ``None`` when an axis has no number."""
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for i, x in enumerate(positions):
        k = i % 3
        if x < lo[k]:
            lo[k] = x
        if x > hi[k]:
            hi[k] = x
    return (tuple(lo), tuple(hi)) if all(lo[k] <= hi[k] for k in range(3)) else None


class Mesh:
    """The host's mesh (the WIT's ``mesh`` resource) with Python types: bulk reads as
    ``array('f')`` / ``array('I')``, bulk edits from any sequence, refused edits as
    :class:`MeshError`. Every edit is recorded by the host. A call costs ~100 ns and a list
    element ~1 ns: read arrays once, compute, write back in bulk."""

    def __init__(self, raw):
        self.raw = raw

    # bulk reads
    def vertex_slots(self) -> int: return self.raw.vertex_slots()
    def triangle_slots(self) -> int: return self.raw.triangle_slots()
    def vertex_count(self) -> int: return self.raw.vertex_count()
    def triangle_count(self) -> int: return self.raw.triangle_count()

    def positions(self) -> array:
        """``x y z`` per vertex slot (removed ones keep their last position)."""
        return array("f", self.raw.positions())

    def triangles(self) -> array:
        """``a b c`` per triangle slot; a removed triangle reads ``0xFFFFFFFF`` three times."""
        return array("I", self.raw.triangles())

    def removed_vertices(self) -> array: return array("I", self.raw.removed_vertices())

    def components(self) -> list:
        """The edge-connected components of the live triangles as ``(first_triangle,
        triangles)``, ascending by first triangle, derived by the host: a filter that only
        chooses whole pieces (removed with :meth:`remove_component`) need not read the mesh."""
        return [(c.first_triangle, c.triangles) for c in self.raw.components()]

    # the whole mesh, for a filter run on partitions (see `filter(…, reach=)`)
    def whole_ids(self) -> array:
        """Per vertex slot, its id in the whole mesh (on the whole mesh, the slot's own): a
        key that stays with a vertex however the mesh is cut."""
        ids = self.raw.whole_ids()
        return array("I", range(self.vertex_slots()) if ids is None else ids)

    def whole_bounds(self, positions):
        """``((min x, y, z), (max x, y, z))`` of the whole mesh as the step received it: on a
        partition, the host's; on the whole mesh, that of ``positions``, which must be what
        ``positions()`` read before any move. ``None`` when no coordinate is a number."""
        given = self.raw.whole_bounds()
        if given is None:
            return bounds_of(positions)
        return (tuple(given[:3]), tuple(given[3:])) if len(given) == 6 else None

    # per element
    def position(self, v: int): return _edit(self.raw.position, v)
    def triangle(self, t: int): return _edit(self.raw.triangle, t)
    def is_vertex_live(self, v: int) -> bool: return self.raw.is_vertex_live(v)
    def is_triangle_live(self, t: int) -> bool: return self.raw.is_triangle_live(t)

    # edits, bulk first
    def set_positions(self, xyz) -> None: _edit(self.raw.set_positions, _list(xyz))
    def move_vertices(self, ids, xyz) -> None: _edit(self.raw.move_vertices, _list(ids), _list(xyz))
    def add_vertices(self, xyz) -> int: return _edit(self.raw.add_vertices, _list(xyz))
    def remove_vertices(self, ids) -> None: _edit(self.raw.remove_vertices, _list(ids))
    def add_triangles(self, abc) -> int: return _edit(self.raw.add_triangles, _list(abc))
    def remove_triangles(self, ids) -> None: _edit(self.raw.remove_triangles, _list(ids))
    def flip_triangles(self, ids) -> None: _edit(self.raw.flip_triangles, _list(ids))
    def transform(self, matrix) -> None: _edit(self.raw.transform, _list(matrix))
    def transform_component(self, t: int, matrix) -> None: _edit(self.raw.transform_component, t, _list(matrix))
    def add_vertex(self, x, y, z) -> int: return _edit(self.raw.add_vertex, x, y, z)
    def move_vertex(self, v, x, y, z) -> None: _edit(self.raw.move_vertex, v, x, y, z)
    def remove_vertex(self, v) -> None: _edit(self.raw.remove_vertex, v)
    def add_triangle(self, a, b, c) -> int: return _edit(self.raw.add_triangle, a, b, c)
    def remove_triangle(self, t) -> None: _edit(self.raw.remove_triangle, t)
    def flip_triangle(self, t) -> None: _edit(self.raw.flip_triangle, t)
    def split_triangle(self, t) -> int: return _edit(self.raw.split_triangle, t)
    def split_triangle_at(self, t, x, y, z) -> int: return _edit(self.raw.split_triangle_at, t, x, y, z)
    def extend_edge(self, e, v) -> int: return _edit(self.raw.extend_edge, e, v)
    def split_edge(self, e) -> int: return _edit(self.raw.split_edge, e)
    def split_edge_at(self, e, x, y, z) -> int: return _edit(self.raw.split_edge_at, e, x, y, z)
    def swap_edge(self, e) -> None: _edit(self.raw.swap_edge, e)
    def collapse_edge(self, e) -> None: _edit(self.raw.collapse_edge, e)
    def remove_component(self, t) -> None: _edit(self.raw.remove_component, t)
    def clear(self) -> None: _edit(self.raw.clear)

    # attributes: whole arrays, one call each; ``domain`` is "vertex", "face" or "corner"
    def attributes(self) -> list[AttributeInfo]:
        """Every attribute the mesh carries, by domain, then name."""
        return [AttributeInfo(_wit_name(a.domain), a.name, a.components, _wit_name(a.number_type))
                for a in self.raw.attributes()]

    def read_attribute(self, domain: str, name: str) -> array | None:
        """An attribute's numbers for every slot of its domain, ``components`` per element,
        as an ``array`` of its type (``B i I f d``); ``None`` when the mesh lacks it."""
        try:
            return _values_to_array(_edit(self.raw.read_attribute, _domain(domain), name))
        except MeshError:
            return None

    def set_attribute(self, domain: str, name: str, components: int, values, ids=None,
                      number_type: str | None = None) -> None:
        """Sets an attribute at ``ids`` (every slot of its domain when ``None``), from an
        ``array`` (its type code gives the number type) or a sequence with ``number_type``.
        An attribute the mesh lacks is made, the other elements at the default. A check gets
        ``read-only``."""
        if not isinstance(values, array):
            values = array(_TYPECODES[number_type or "f32"], values)
        _edit(self.raw.set_attribute, _domain(domain), name, components,
              None if ids is None else _list(ids), _values_from_array(values))

    def remove_attribute(self, domain: str, name: str) -> None:
        _edit(self.raw.remove_attribute, _domain(domain), name)

    def vertex_colors(self) -> array | None:
        """``r g b a`` bytes per vertex slot (``array('B')``), if the mesh has colours."""
        return self.read_attribute("vertex", "color")

    def set_vertex_colors(self, rgba, ids=None) -> None:
        self.set_attribute("vertex", "color", 4, array("B", rgba), ids)

    def quality(self) -> array | None:
        """Quality per vertex slot (``array('f')``), if the mesh has it."""
        return self.read_attribute("vertex", "quality")

    def set_quality(self, quality, ids=None) -> None:
        self.set_attribute("vertex", "quality", 1, array("f", quality), ids)


# ---- native runs (plain CPython, for unit tests of an algorithm) -----------------------------
class NativeMesh:
    """A stand-in for the host's mesh in plain CPython, with the bulk reads, the
    position edits (``set_positions``, ``move_vertices``, ``transform``) and attributes
    (``attributes_by_name``, read and written as :class:`Mesh` does): enough to test a
    smoothing, deformation or quality-writing service with pytest before building the
    component."""

    def __init__(self, positions, triangles, attributes=None):
        self._p = array("f", positions)
        self._t = array("I", triangles)
        self.edits = 0
        # (domain, name) -> (components, array): e.g. {("vertex", "quality"): (1, array("f", ...))}
        self.attributes_by_name = dict(attributes or {})

    def vertex_slots(self): return len(self._p) // 3
    def triangle_slots(self): return len(self._t) // 3
    vertex_count = vertex_slots
    triangle_count = triangle_slots
    def positions(self): return array("f", self._p)
    def triangles(self): return array("I", self._t)
    def whole_ids(self): return array("I", range(len(self._p) // 3))
    def whole_bounds(self, positions): return bounds_of(positions)

    def set_positions(self, xyz):
        if len(xyz) != len(self._p):
            raise MeshError("invalid-argument", f"{len(xyz)} coordinates for {len(self._p) // 3} vertex slots")
        self._p = array("f", xyz)
        self.edits += 1

    def move_vertices(self, ids, xyz):
        for k, v in enumerate(ids):
            self._p[3 * v:3 * v + 3] = array("f", xyz[3 * k:3 * k + 3])
        self.edits += 1

    def transform(self, m):
        p = self._p
        for i in range(0, len(p), 3):
            x, y, z = p[i], p[i + 1], p[i + 2]
            p[i], p[i + 1], p[i + 2] = (m[0] * x + m[1] * y + m[2] * z + m[3],
                                        m[4] * x + m[5] * y + m[6] * z + m[7],
                                        m[8] * x + m[9] * y + m[10] * z + m[11])
        self.edits += 1


    # attributes, as Mesh has them (no shape checks beyond the element count)
    def attributes(self) -> list[AttributeInfo]:
        order = {"vertex": 0, "face": 1, "corner": 2}
        return [AttributeInfo(d, n, c, _NUMBER_TYPES[v.typecode])
                for (d, n), (c, v) in sorted(self.attributes_by_name.items(),
                                             key=lambda kv: (order[kv[0][0]], kv[0][1]))]

    def read_attribute(self, domain: str, name: str) -> array | None:
        found = self.attributes_by_name.get((domain, name))
        return None if found is None else array(found[1].typecode, found[1])

    def set_attribute(self, domain: str, name: str, components: int, values, ids=None,
                      number_type: str | None = None) -> None:
        if not isinstance(values, array):
            values = array(_TYPECODES[number_type or "f32"], values)
        slots = {"vertex": self.vertex_slots(), "face": self.triangle_slots(),
                 "corner": 3 * self.triangle_slots()}[domain]
        count = slots if ids is None else len(ids)
        if len(values) != components * count:
            raise MeshError("invalid-argument", f"{count} elements need {components * count} numbers, got {len(values)}")
        if ids is None:
            self.attributes_by_name[(domain, name)] = (components, array(values.typecode, values))
        else:
            default = 255 if (domain, name) == ("vertex", "color") else 0
            _, old = self.attributes_by_name.get(
                (domain, name), (components, array(values.typecode, [default] * (components * slots))))
            for j, i in enumerate(ids):
                old[components * i:components * (i + 1)] = values[components * j:components * (j + 1)]
            self.attributes_by_name[(domain, name)] = (components, old)
        self.edits += 1

    def remove_attribute(self, domain: str, name: str) -> None:
        if self.attributes_by_name.pop((domain, name), None) is None:
            raise MeshError("not-applicable", f"the mesh has no {domain} attribute {name}")
        self.edits += 1

    vertex_colors = Mesh.vertex_colors
    set_vertex_colors = Mesh.set_vertex_colors
    quality = Mesh.quality
    set_quality = Mesh.set_quality


def run_native(name: str, mesh: NativeMesh, **params: Any):
    """Runs a declared service on a :class:`NativeMesh` with the declared defaults filled
    in (keyword ``_`` → ``-``); returns ``(value or None, report)``."""
    svc = _SERVICES[name]
    values = {p.name: p.default for p in svc.params}
    values.update({k.rstrip("_").replace("_", "-"): v for k, v in params.items()})
    unknown = set(values) - {p.name for p in svc.params}
    if unknown:
        raise ServiceError(f"{name}: unknown parameter(s) {sorted(unknown)}")
    return _call(svc, mesh, values)
