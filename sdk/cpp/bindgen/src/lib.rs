//! The C bindings of the `meshflow:geometry` plugin world, generated from `wit/` by
//! wit-bindgen's C generator. `cargo run -p meshflow-c-bindgen` rewrites
//! `sdk/cpp/generated/`; the test below fails when those files are stale.
//!
//! This crate is a build tool of the repository: nothing links it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use wit_bindgen_core::wit_parser::Resolve;

/// The folder holding the generated files.
pub fn generated_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../generated")
}

/// Every generated file, by name: `plugin.h`, `plugin.c` and the object file carrying the
/// world's type (`plugin_component_type.o`), which `meshflow plugin componentize` reads.
pub fn generate() -> Result<Vec<(String, Vec<u8>)>> {
    let wit = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../wit");
    let mut resolve = Resolve::default();
    let (package, _) =
        resolve.push_path(&wit).with_context(|| format!("parsing {}", wit.display()))?;
    // World `block-plugin` (a plugin that may declare its services' reach and block size),
    // its generated names kept as world `plugin`'s: `plugin.h`, `plugin_string_t`, …
    let world = resolve.select_world(&[package], Some("block-plugin"))?;
    let mut files = wit_bindgen_core::Files::default();
    let opts = wit_bindgen_c::Opts { rename_world: Some("plugin".into()), ..Default::default() };
    opts.build().generate(&mut resolve, world, &mut files)?;
    Ok(files.iter().map(|(name, bytes)| (name.to_owned(), bytes.to_vec())).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn committed_c_bindings_match_the_wit() {
        for (name, bytes) in generate().unwrap() {
            let path = generated_dir().join(&name);
            let committed = std::fs::read(&path).unwrap_or_else(|e| {
                panic!("{}: {e}; run `cargo run -p meshflow-c-bindgen`", path.display())
            });
            assert!(
                committed == bytes,
                "{} is stale relative to wit/: run `cargo run -p meshflow-c-bindgen` and commit it",
                path.display()
            );
        }
    }
}
