//! The generated bindings of the `meshflow:geometry` `block-plugin` world (a plugin that also
//! says which services may run on partitions, and which block by block). The SDK's own types wrap
//! them; plugin authors rarely need to look in here.

wit_bindgen::generate!({
    path: "../wit",
    world: "block-plugin",
    pub_export_macro: true,
    export_macro_name: "export_component",
    default_bindings_module: "meshflow_plugin_sdk::bindings",
    runtime_path: "meshflow_plugin_sdk::__private::wit_bindgen::rt",
});
