//! `meshflow hash` and `meshflow info`: facts about a mesh file.

use crate::output::out;
use std::path::Path;

use meshflow_meshio as io;

/// The hash covers positions, triangles and the attributes the mesh keeps; what the file
/// held beyond them is named on stderr, since two files differing only there hash the same.
pub fn hash(input: &Path) -> anyhow::Result<()> {
    let mesh = super::pack::load_mesh(input)?;
    out!("{}", mesh.content_hash());
    Ok(())
}

pub fn info(input: &Path, json: bool) -> anyhow::Result<()> {
    let io::Loaded { mesh, dropped } = io::load_reporting(input)?;
    let bbox = mesh.bounding_box();
    let not_kept = dropped.lines();
    if json {
        let bbox = bbox.map(|(lo, hi)| serde_json::json!({ "min": lo, "max": hi }));
        let info = serde_json::json!({
            "vertices": mesh.vertex_count(),
            "triangles": mesh.triangle_count(),
            "bbox": bbox,
            "attributes": mesh.attributes.describe(),
            "not_kept": not_kept,
        });
        out!("{info}");
    } else {
        out!("vertices:  {}", mesh.vertex_count());
        out!("triangles: {}", mesh.triangle_count());
        match bbox {
            Some((lo, hi)) => out!("bbox:      {lo:?} .. {hi:?}"),
            None => out!("bbox:      (empty)"),
        }
        for line in mesh.attributes.describe() {
            out!("attribute: {line}");
        }
        // What meshflow could not keep of the file is named.
        for line in &not_kept {
            out!("not kept:  {line}");
        }
    }
    Ok(())
}
