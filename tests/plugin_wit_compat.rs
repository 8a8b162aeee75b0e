//! Plugins built against an older `wit/meshflow.wit` of the same package version keep
//! loading: the WIT grows only by additions (functions, types), which a component built
//! before them does not import, as the architecture doc's WIT section says.
//! `tests/data/wit-0.1.0-before-attributes.wit` is the WIT before the attribute calls. A
//! component that imports every function of its `mesh` interface (more than any real plugin,
//! whose bindings import only what it calls) must link against today's host; one that
//! imports a function the host lacks must not.

use meshflow_runtime::{Limits, PluginError, Runtime};
use wit_component::{ComponentEncoder, StringEncoding, embed_component_metadata};
use wit_parser::abi::{AbiVariant, WasmType};
use wit_parser::{
    LiftLowerAbi, ManglingAndAbi, Resolve, ResourceIntrinsic, WasmExport, WasmExportKind,
    WasmImport, WorldItem,
};

const LEGACY: ManglingAndAbi = ManglingAndAbi::Legacy(LiftLowerAbi::Sync);

/// A component of `wit`'s `plugin` world: a core module importing every function (and the
/// resource drops) of the world's imported interfaces, with the world's exports as
/// functions that trap, encoded by wit-component as `meshflow plugin componentize` does.
fn component_of(wit: &str) -> Vec<u8> {
    let mut resolve = Resolve::default();
    let package = resolve.push_str("meshflow.wit", wit).expect("the WIT parses");
    let world_id = resolve.select_world(&[package], Some("plugin")).expect("its plugin world");
    let world = &resolve.worlds[world_id];
    let mut module = CoreModule::default();
    for (key, item) in &world.imports {
        let WorldItem::Interface { id, .. } = item else { continue };
        let interface = &resolve.interfaces[*id];
        for func in interface.functions.values() {
            let import = WasmImport::Func { interface: Some(key), func };
            let (field_module, name) = resolve.wasm_import_name(LEGACY, import);
            let signature = resolve.wasm_signature(AbiVariant::GuestImport, func);
            module.import(&field_module, &name, &signature.params, &signature.results);
        }
        for (_, &ty) in &interface.types {
            if let wit_parser::TypeDefKind::Resource = resolve.types[ty].kind {
                let import = WasmImport::ResourceIntrinsic {
                    interface: Some(key),
                    resource: ty,
                    intrinsic: ResourceIntrinsic::ImportedDrop,
                };
                let (field_module, name) = resolve.wasm_import_name(LEGACY, import);
                module.import(&field_module, &name, &[WasmType::I32], &[]);
            }
        }
    }
    for (key, item) in &world.exports {
        let WorldItem::Interface { id, .. } = item else { continue };
        for func in resolve.interfaces[*id].functions.values() {
            let export =
                WasmExport::Func { interface: Some(key), func, kind: WasmExportKind::Normal };
            let name = resolve.wasm_export_name(LEGACY, export);
            let signature = resolve.wasm_signature(AbiVariant::GuestExport, func);
            module.export(&name, &signature.params, &signature.results);
        }
    }
    module.export("cabi_realloc", &[WasmType::I32; 4], &[WasmType::I32]);
    let mut bytes = module.encode();
    embed_component_metadata(&mut bytes, &resolve, world_id, StringEncoding::UTF8).unwrap();
    ComponentEncoder::default().module(&bytes).unwrap().validate(true).encode().unwrap()
}

/// The few sections such a module needs, written by hand (wit-component's own dummy module
/// needs its `wat` feature, which the workspace does not build).
#[derive(Default)]
struct CoreModule {
    types: Vec<(Vec<u8>, Vec<u8>)>,
    imports: Vec<(String, String, u32)>,
    exports: Vec<(String, u32)>,
}

impl CoreModule {
    fn signature(&mut self, params: &[WasmType], results: &[WasmType]) -> u32 {
        let code = |ty: &WasmType| match ty {
            WasmType::I64 | WasmType::PointerOrI64 => 0x7e,
            WasmType::F32 => 0x7d,
            WasmType::F64 => 0x7c,
            WasmType::I32 | WasmType::Pointer | WasmType::Length => 0x7f,
        };
        self.types.push((params.iter().map(code).collect(), results.iter().map(code).collect()));
        self.types.len() as u32 - 1
    }

    fn import(&mut self, module: &str, name: &str, params: &[WasmType], results: &[WasmType]) {
        let ty = self.signature(params, results);
        self.imports.push((module.to_owned(), name.to_owned(), ty));
    }

    fn export(&mut self, name: &str, params: &[WasmType], results: &[WasmType]) {
        let ty = self.signature(params, results);
        self.exports.push((name.to_owned(), ty));
    }

    fn encode(&self) -> Vec<u8> {
        let mut out = b"\0asm\x01\0\0\0".to_vec();
        let mut types = leb(self.types.len() as u32);
        for (params, results) in &self.types {
            types.push(0x60);
            types.extend(leb(params.len() as u32));
            types.extend(params);
            types.extend(leb(results.len() as u32));
            types.extend(results);
        }
        section(&mut out, 1, types);
        let mut imports = leb(self.imports.len() as u32);
        for (module, name, ty) in &self.imports {
            imports.extend(string(module));
            imports.extend(string(name));
            imports.push(0x00);
            imports.extend(leb(*ty));
        }
        section(&mut out, 2, imports);
        let mut functions = leb(self.exports.len() as u32);
        self.exports.iter().for_each(|(_, ty)| functions.extend(leb(*ty)));
        section(&mut out, 3, functions);
        section(&mut out, 5, vec![1, 0x00, 1]); // one memory of one page
        let mut exports = leb(self.exports.len() as u32 + 1);
        exports.extend(string("memory"));
        exports.extend([0x02, 0]);
        for (i, (name, _)) in self.exports.iter().enumerate() {
            exports.extend(string(name));
            exports.push(0x00);
            exports.extend(leb((self.imports.len() + i) as u32));
        }
        section(&mut out, 7, exports);
        let mut code = leb(self.exports.len() as u32);
        for _ in &self.exports {
            code.extend([3, 0, 0x00, 0x0b]); // no locals; unreachable; end
        }
        section(&mut out, 10, code);
        out
    }
}

fn leb(mut value: u32) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let byte = (value & 0x7f) as u8;
        value >>= 7;
        if value == 0 {
            out.push(byte);
            return out;
        }
        out.push(byte | 0x80);
    }
}

fn string(text: &str) -> Vec<u8> {
    let mut out = leb(text.len() as u32);
    out.extend(text.as_bytes());
    out
}

fn section(out: &mut Vec<u8>, id: u8, body: Vec<u8>) {
    out.push(id);
    out.extend(leb(body.len() as u32));
    out.extend(body);
}

fn load(wit: &str) -> PluginError {
    let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
    match runtime.load(&component_of(wit)) {
        Ok(_) => panic!("a plugin whose every function traps described itself"),
        Err(e) => e,
    }
}

#[test]
fn a_plugin_of_the_wit_before_attributes_still_links() {
    let old = include_str!("data/wit-0.1.0-before-attributes.wit");
    assert!(!old.contains("read-attribute") && old.contains("meshflow:geometry@0.1.0"));
    // Linked: it got as far as calling `describe`, which traps in this stand-in.
    let error = load(old);
    assert!(matches!(error, PluginError::Describe(_)), "{error}");
    // Today's WIT, all of it, likewise.
    let today = include_str!("../wit/meshflow.wit");
    assert!(today.contains("read-attribute"));
    let error = load(today);
    assert!(matches!(error, PluginError::Describe(_)), "{error}");
}

#[test]
fn a_plugin_importing_what_the_host_lacks_does_not_link() {
    let today = include_str!("../wit/meshflow.wit");
    let unknown = today.replace(
        "        clear: func() -> result<_, edit-error>;",
        "        clear: func() -> result<_, edit-error>;\n        no-such-call: func() -> u32;",
    );
    assert_ne!(unknown, today);
    let error = load(&unknown);
    assert!(matches!(error, PluginError::World(_)), "{error}");
    assert!(error.to_string().contains("no-such-call"), "{error}");
}
