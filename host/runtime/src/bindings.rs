//! Host-side bindings of the `meshflow:geometry` plugin world (the one `bindgen!`), and
//! the conversions between its types and `meshflow-params`, at this edge only.

wasmtime::component::bindgen!({
    path: "../../wit",
    world: "plugin",
    with: {
        "meshflow:geometry/mesh.mesh": super::state::MeshHandle,
    },
    // Host functions may trap: that is how a run that exceeds its edit budget is stopped.
    imports: { default: trappable },
});

pub use exports::meshflow::geometry::service::{Param, ServiceInfo};
pub use meshflow::geometry::mesh::{
    AttributeDomain, AttributeInfo, AttributeValues, Component, NumberType,
};
pub use meshflow::geometry::types::{
    EditError, EditErrorKind, ParamInfo, ServiceKind, Value, ValueType,
};

use meshflow_mesh::attributes::{self as model, Domain, Values};
use meshflow_mesh::calls;
use meshflow_params as params;

impl From<AttributeDomain> for Domain {
    fn from(domain: AttributeDomain) -> Self {
        match domain {
            AttributeDomain::Vertex => Domain::Vertex,
            AttributeDomain::Face => Domain::Face,
            AttributeDomain::Corner => Domain::Corner,
        }
    }
}

impl From<Domain> for AttributeDomain {
    fn from(domain: Domain) -> Self {
        match domain {
            Domain::Vertex => AttributeDomain::Vertex,
            Domain::Face => AttributeDomain::Face,
            Domain::Corner => AttributeDomain::Corner,
        }
    }
}

impl From<model::NumberType> for NumberType {
    fn from(ty: model::NumberType) -> Self {
        match ty {
            model::NumberType::U8 => NumberType::U8,
            model::NumberType::I32 => NumberType::S32,
            model::NumberType::U32 => NumberType::U32,
            model::NumberType::F32 => NumberType::F32,
            model::NumberType::F64 => NumberType::F64,
        }
    }
}

impl From<calls::AttributeInfo> for AttributeInfo {
    fn from(info: calls::AttributeInfo) -> Self {
        AttributeInfo {
            domain: info.domain.into(),
            name: info.name,
            components: info.components,
            number_type: info.number_type.into(),
        }
    }
}

impl From<meshflow_mesh::store::Component> for Component {
    fn from(c: meshflow_mesh::store::Component) -> Self {
        Component { first_triangle: c.first_triangle, triangles: c.triangles }
    }
}

impl From<AttributeValues> for Values {
    fn from(values: AttributeValues) -> Self {
        match values {
            AttributeValues::U8(v) => Values::U8(v),
            AttributeValues::S32(v) => Values::I32(v),
            AttributeValues::U32(v) => Values::U32(v),
            AttributeValues::F32(v) => Values::F32(v),
            AttributeValues::F64(v) => Values::F64(v),
        }
    }
}

impl From<Values> for AttributeValues {
    fn from(values: Values) -> Self {
        match values {
            Values::U8(v) => AttributeValues::U8(v),
            Values::I32(v) => AttributeValues::S32(v),
            Values::U32(v) => AttributeValues::U32(v),
            Values::F32(v) => AttributeValues::F32(v),
            Values::F64(v) => AttributeValues::F64(v),
        }
    }
}

impl From<ServiceInfo> for params::ServiceInfo {
    fn from(info: ServiceInfo) -> Self {
        params::ServiceInfo {
            name: info.name,
            kind: match info.kind {
                ServiceKind::Filter => params::ServiceKind::Filter,
                ServiceKind::Check => params::ServiceKind::Check,
            },
            doc: info.doc,
            params: info.params.into_iter().map(Into::into).collect(),
            result_type: info.result_type.map(Into::into),
        }
    }
}

impl From<ParamInfo> for params::ParamInfo {
    fn from(p: ParamInfo) -> Self {
        params::ParamInfo {
            name: p.name,
            ty: p.ty.into(),
            default: p.default.into(),
            min: p.min,
            max: p.max,
            choices: p.choices,
            doc: p.doc,
        }
    }
}

impl From<ValueType> for params::ValueType {
    fn from(ty: ValueType) -> Self {
        match ty {
            ValueType::Boolean => params::ValueType::Boolean,
            ValueType::Integer => params::ValueType::Integer,
            ValueType::Real => params::ValueType::Real,
            ValueType::Text => params::ValueType::Text,
        }
    }
}

impl From<Value> for params::Value {
    fn from(value: Value) -> Self {
        match value {
            Value::Boolean(b) => params::Value::Boolean(b),
            Value::Integer(i) => params::Value::Integer(i),
            Value::Real(r) => params::Value::Real(r),
            Value::Text(t) => params::Value::Text(t),
        }
    }
}

impl From<params::Value> for Value {
    fn from(value: params::Value) -> Self {
        match value {
            params::Value::Boolean(b) => Value::Boolean(b),
            params::Value::Integer(i) => Value::Integer(i),
            params::Value::Real(r) => Value::Real(r),
            params::Value::Text(t) => Value::Text(t),
        }
    }
}
