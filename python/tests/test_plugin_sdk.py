"""sdk/python's Service (describe, run, errors) in plain CPython, with stand-ins for the
modules componentize-py generates from wit/ (the component test builds the real ones)."""

import enum
import sys
import types as pytypes
from dataclasses import dataclass

import pytest

from conftest import ROOT


@pytest.fixture()
def sdk(monkeypatch):
    cpt = pytypes.ModuleType("componentize_py_types")

    @dataclass(frozen=True)
    class Err(Exception):
        value: object

    cpt.Err = Err
    t = pytypes.ModuleType("wit_world.imports.types")
    t.ValueType = enum.Enum("ValueType", "BOOLEAN INTEGER REAL TEXT")
    t.ServiceKind = enum.Enum("ServiceKind", "FILTER CHECK")
    t.EditErrorKind = enum.Enum("EditErrorKind", "INVALID_VERTEX NOT_APPLICABLE READ_ONLY")
    for name in ("Boolean", "Integer", "Real", "Text"):
        setattr(t, f"Value_{name}", dataclass(type(f"Value_{name}", (), {"__annotations__": {"value": object}})))
    for name, fields in (("ParamInfo", "name doc ty default min max choices"),
                         ("ServiceInfo", "name kind doc params result_type"),
                         ("Param", "name value"), ("Outcome", "value report"),
                         ("EditError", "kind message")):
        setattr(t, name, dataclass(type(name, (), {"__annotations__": {f: object for f in fields.split()}})))
    world = pytypes.ModuleType("wit_world")
    imports = pytypes.ModuleType("wit_world.imports")
    imports.types = t
    world.imports = imports
    for name, mod in (("componentize_py_types", cpt), ("wit_world", world),
                      ("wit_world.imports", imports), ("wit_world.imports.types", t)):
        monkeypatch.setitem(sys.modules, name, mod)
    monkeypatch.syspath_prepend(str(ROOT / "sdk" / "python"))
    sys.modules.pop("meshflow_plugin", None)
    import meshflow_plugin

    yield meshflow_plugin, t, Err
    sys.modules.pop("meshflow_plugin", None)


class RawMesh:
    def __init__(self, err):
        self.err = err
        self.set = None

    def positions(self):
        return [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]

    def triangles(self):
        return [0, 1, 2]

    def vertex_count(self):
        return 3

    def set_positions(self, xyz):
        assert type(xyz) is list
        self.set = xyz

    def remove_vertex(self, v):
        raise self.err


def test_describe_run_and_errors(sdk):
    mp, t, Err = sdk

    @mp.filter("lift-py", "Lifts.", params=[mp.Real("dz", 1.0, min=-10, max=10, doc="dz"),
                                            mp.Text("how", "up", choices=["up", "down"])])
    def lift(mesh, params):
        p = mesh.positions()
        for i in range(2, len(p), 3):
            p[i] += params["dz"]
        mesh.set_positions(p)
        return f"lifted {mesh.vertex_count()}"

    @mp.check("count-py", "Counts.", result="integer")
    def count(mesh, params):
        return mesh.vertex_count(), "three"

    @mp.filter("bad-edit-py", "Refused edit.")
    def bad_edit(mesh, params):
        mesh.remove_vertex(7)

    @mp.filter("raises-py", "Raises.")
    def raises(mesh, params):
        raise ZeroDivisionError("boom")

    svc = mp.Service()
    infos = {i.name: i for i in svc.describe()}
    assert infos["lift-py"].kind == t.ServiceKind.FILTER and infos["lift-py"].result_type is None
    dz = infos["lift-py"].params[0]
    assert (dz.ty, dz.default, dz.min, dz.max) == (t.ValueType.REAL, t.Value_Real(1.0), -10.0, 10.0)
    assert infos["lift-py"].params[1].choices == ["up", "down"]
    assert infos["count-py"].result_type == t.ValueType.INTEGER

    raw = RawMesh(None)
    out = svc.run("lift-py", raw, [t.Param("dz", t.Value_Real(2.0)), t.Param("how", t.Value_Text("up"))])
    assert out == t.Outcome(None, "lifted 3") and raw.set[2::3] == [2.0, 2.0, 2.0]
    assert svc.run("count-py", raw, []) == t.Outcome(t.Value_Integer(3), "three")

    refused = RawMesh(Err(t.EditError(t.EditErrorKind.INVALID_VERTEX, "vertex 7 is out of range")))
    with pytest.raises(Err) as e:
        svc.run("bad-edit-py", refused, [])
    assert e.value.value == "bad-edit-py: invalid-vertex: vertex 7 is out of range"
    with pytest.raises(Err) as e:
        svc.run("raises-py", raw, [])
    assert e.value.value == "raises-py: ZeroDivisionError: boom"
    with pytest.raises(Err) as e:
        svc.run("nope", raw, [])
    assert "unknown service" in e.value.value
    with pytest.raises(ValueError):
        mp.filter("lift-py", "again")(lambda m, p: None)


@pytest.fixture()
def with_mesh_types(sdk, monkeypatch):
    """sdk plus a stand-in for the WIT `mesh` interface's attribute types."""
    mp, t, Err = sdk
    m = pytypes.ModuleType("wit_world.imports.mesh")
    m.AttributeDomain = enum.Enum("AttributeDomain", "VERTEX FACE CORNER")
    m.NumberType = enum.Enum("NumberType", "U8 S32 U32 F32 F64")
    for ty in ("U8", "S32", "U32", "F32", "F64"):
        setattr(m, f"AttributeValues_{ty}",
                dataclass(type(f"AttributeValues_{ty}", (), {"__annotations__": {"value": object}})))
    m.AttributeInfo = dataclass(type("AttributeInfo", (), {
        "__annotations__": {f: object for f in "domain name components number_type".split()}}))
    sys.modules["wit_world.imports"].mesh = m
    monkeypatch.setitem(sys.modules, "wit_world.imports.mesh", m)
    return mp, t, Err, m


class AttributeMesh:
    """The host's attribute calls over a dict, as the stand-in bindings type them."""

    def __init__(self, m, err, read_only=False):
        self.m, self.err, self.read_only = m, err, read_only
        self.values = {("VERTEX", "color"): (4, m.AttributeValues_U8(bytes([0, 0, 0, 255, 200, 100, 0, 255, 9, 9, 9, 9]))),
                       ("VERTEX", "quality"): (1, m.AttributeValues_F32([0.0, 1.0, 0.0]))}

    def vertex_slots(self):
        return 3

    def attributes(self):
        return [self.m.AttributeInfo(getattr(self.m.AttributeDomain, d), n, c,
                                     getattr(self.m.NumberType, type(v).__name__.rsplit("_", 1)[-1]))
                for (d, n), (c, v) in sorted(self.values.items())]

    def read_attribute(self, domain, name):
        if (domain.name, name) not in self.values:
            raise self.err("no such attribute")
        return self.values[(domain.name, name)][1]

    def set_attribute(self, domain, name, components, ids, values):
        if self.read_only:
            raise self.err("read-only")
        key = (domain.name, name)
        if ids is None:
            self.values[key] = (components, values)
            return
        old = list(self.values[key][1].value)
        for j, i in enumerate(ids):
            old[components * i:components * (i + 1)] = list(values.value)[components * j:components * (j + 1)]
        kind = type(values)
        self.values[key] = (components, kind(bytes(old) if isinstance(values.value, bytes) else old))

    def remove_attribute(self, domain, name):
        if self.read_only:
            raise self.err("read-only")
        del self.values[(domain.name, name)]


def test_attributes_read_write_and_blend(with_mesh_types):
    mp, t, Err, m = with_mesh_types
    edit_error = lambda message: Err(t.EditError(t.EditErrorKind.NOT_APPLICABLE, message))
    raw = AttributeMesh(m, edit_error)
    mesh = mp.Mesh(raw)
    assert mesh.attributes() == [mp.AttributeInfo("vertex", "color", 4, "u8"),
                                 mp.AttributeInfo("vertex", "quality", 1, "f32")]
    assert mesh.vertex_colors()[4:8].tolist() == [200, 100, 0, 255]
    assert mesh.quality().typecode == "f"
    assert mesh.read_attribute("face", "label") is None
    mesh.set_quality([2.0, 4.0, 8.0])
    assert raw.values[("VERTEX", "quality")][1] == m.AttributeValues_F32([2.0, 4.0, 8.0])
    mesh.set_attribute("face", "label", 1, [7], number_type="s32")
    assert raw.values[("FACE", "label")] == (1, m.AttributeValues_S32([7]))
    # Vertex 2 halfway between 0 and 1 (colours round to nearest, ties away from zero).
    assert mp.blend_new_vertex_attributes(mesh, [(2, [(0, 1.0), (1, 1.0)])]) == 2
    assert list(raw.values[("VERTEX", "color")][1].value) == [0, 0, 0, 255, 200, 100, 0, 255,
                                                              100, 50, 0, 255]
    assert raw.values[("VERTEX", "quality")][1].value == [2.0, 4.0, 3.0]
    with pytest.raises(mp.ServiceError):
        mp.blend_new_vertex_attributes(mesh, [(2, [(0, -1.0)])])
    mesh.remove_attribute("face", "label")
    assert ("FACE", "label") not in raw.values

    check = mp.Mesh(AttributeMesh(m, lambda message: Err(t.EditError(t.EditErrorKind.READ_ONLY, message)),
                                  read_only=True))
    with pytest.raises(mp.MeshError) as e:
        check.set_quality([0.0, 0.0, 0.0])
    assert e.value.kind == "read-only"


def test_native_mesh_attributes(sdk):
    mp, t, Err = sdk
    from array import array

    @mp.filter("height-quality-py", "Writes the height as quality.")
    def height(mesh, params):
        p = mesh.positions()
        mesh.set_quality(p[2::3])
        colours = mesh.vertex_colors()
        return f"{len(mesh.quality())} {colours is None}"

    mesh = mp.NativeMesh([0, 0, 0, 1, 0, 1, 0, 1, 2], [0, 1, 2])
    assert mp.run_native("height-quality-py", mesh) == (None, "3 True")
    assert mesh.quality().tolist() == [0.0, 1.0, 2.0]
    mesh.set_vertex_colors([1, 2, 3, 4], ids=[1])
    assert mesh.vertex_colors().tolist() == [255] * 4 + [1, 2, 3, 4] + [255] * 4
    assert mesh.attributes() == [mp.AttributeInfo("vertex", "color", 4, "u8"),
                                 mp.AttributeInfo("vertex", "quality", 1, "f32")]
    assert mp.blend_new_vertex_attributes(mesh, [(2, [(0, 1.0), (1, 3.0)])]) == 2
    assert mesh.quality().tolist() == [0.0, 1.0, 0.75]
    assert mesh.vertex_colors()[8:].tolist() == [65, 65, 66, 67]  # 64.5 rounds away from 0
    with pytest.raises(mp.MeshError):
        mesh.set_quality([1.0])
    mesh.remove_attribute("vertex", "color")
    assert mesh.vertex_colors() is None


def test_a_filter_declares_its_reach_to_the_locality_export(sdk):
    mp, t, Err = sdk

    @mp.filter("smooth-py", "Smooths.", params=[mp.Integer("iterations", 1, min=1, max=9)],
               reach=lambda params: params["iterations"])
    def smooth(mesh, params):
        return ""

    @mp.filter("fixed-py", "Reaches one ring.", reach=1)
    def fixed(mesh, params):
        return ""

    @mp.filter("global-py", "Reads the whole mesh.")
    def whole(mesh, params):
        return ""

    @mp.filter("lying-py", "Says a negative reach.", reach=lambda params: -1)
    def lying(mesh, params):
        return ""

    locality = mp.Locality()
    assert locality.reach("smooth-py", [t.Param("iterations", t.Value_Integer(3))]) == 3
    assert locality.reach("fixed-py", []) == 1
    # Not local, unknown, or no ring count a u32 holds: the host runs it whole.
    assert locality.reach("global-py", []) is None
    assert locality.reach("nope", []) is None
    assert locality.reach("lying-py", []) is None


def test_a_filter_declares_its_blocks_to_the_blocks_export(sdk):
    mp, t, Err = sdk

    @mp.filter("simplify-py", "Simplifies.", params=[mp.Integer("block-triangles", 5000, min=0)],
               blocks=lambda params: params["block-triangles"] or None)
    @mp.filter("fixed-blocks-py", "Blocks of 4000 triangles, and a reach.", reach=2, blocks=4000)
    @mp.filter("whole-py", "Runs whole.")
    @mp.filter("huge-py", "Says more triangles than a u32 holds.", blocks=lambda params: 2**32)
    def simplify(mesh, params):
        return ""

    @mp.check("count-py", "Counts.", result="integer")
    def count(mesh, params):
        return 0

    blocks = mp.Blocks()
    assert blocks.block_triangles("simplify-py", [t.Param("block-triangles", t.Value_Integer(1200))]) == 1200
    assert blocks.block_triangles("fixed-blocks-py", []) == 4000
    # Both declarations are answered, each by its own export.
    assert mp.Locality().reach("fixed-blocks-py", []) == 2
    assert mp.Locality().reach("simplify-py", []) is None
    # None or 0 from the filter, no declaration, a check, an unknown service, or no count a
    # u32 holds: none, the host runs it whole.
    assert blocks.block_triangles("simplify-py", [t.Param("block-triangles", t.Value_Integer(0))]) is None
    for name in ("whole-py", "count-py", "nope", "huge-py"):
        assert blocks.block_triangles(name, []) is None, name


class PartitionMesh(RawMesh):
    """A partition of a larger mesh: the host says what it is part of."""

    def vertex_slots(self):
        return 3

    def whole_ids(self):
        return [5, 9, 40]

    def whole_bounds(self):
        return [-1.0, -2.0, -3.0, 4.0, 5.0, 6.0]


def test_the_whole_mesh_as_a_partition_and_a_whole_mesh_see_it(sdk):
    mp, t, Err = sdk

    class WholeMesh(RawMesh):
        def vertex_slots(self):
            return 3

        def whole_ids(self):
            return None

        def whole_bounds(self):
            return None

    whole = mp.Mesh(WholeMesh(None))
    assert list(whole.whole_ids()) == [0, 1, 2]
    assert whole.whole_bounds(whole.positions()) == ((0.0, 0.0, 0.0), (1.0, 1.0, 0.0))
    part = mp.Mesh(PartitionMesh(None))
    assert list(part.whole_ids()) == [5, 9, 40]
    assert part.whole_bounds(part.positions()) == ((-1.0, -2.0, -3.0), (4.0, 5.0, 6.0))
    native = mp.NativeMesh([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], [0, 1, 2])
    assert list(native.whole_ids()) == [0, 1, 2]
    assert native.whole_bounds(native.positions()) == whole.whole_bounds(whole.positions())
    # NaNs are skipped; an axis without a number gives no box.
    nan = float("nan")
    assert mp.bounds_of([nan, 1.0, 2.0, 3.0, nan, 4.0]) == ((3.0, 1.0, 2.0), (3.0, 1.0, 4.0))
    assert mp.bounds_of([nan, 1.0, 2.0]) is None
