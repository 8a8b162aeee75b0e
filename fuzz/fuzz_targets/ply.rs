//! Any bytes as PLY: see `mesh_reader::check`.
#![no_main]

mod mesh_reader;

libfuzzer_sys::fuzz_target!(|data: &[u8]| mesh_reader::check(data, meshflow_meshio::Format::Ply));
