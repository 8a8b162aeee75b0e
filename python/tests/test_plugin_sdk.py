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
