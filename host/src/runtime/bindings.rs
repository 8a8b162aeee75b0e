//! Host-side bindings of the `meshflow:geometry` plugin world (the one `bindgen!`).

wasmtime::component::bindgen!({
    path: "../wit",
    world: "plugin",
    with: {
        "meshflow:geometry/mesh.mesh": super::state::MeshHandle,
    },
    // Host functions may trap: that is how a run that exceeds its edit budget is stopped.
    imports: { default: trappable },
    additional_derives: [PartialEq, serde::Serialize, serde::Deserialize],
});

pub use exports::meshflow::geometry::service::{Outcome, Param, ServiceInfo};
pub use meshflow::geometry::types::{
    EditError, EditErrorKind, ParamInfo, ServiceKind, Value, ValueType,
};
