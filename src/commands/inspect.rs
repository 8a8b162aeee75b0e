//! `meshflow hash` and `meshflow info`: facts about a mesh file.

use crate::output::out;
use std::path::Path;

use meshflow_meshio as io;

pub fn hash(input: &Path) -> anyhow::Result<()> {
    let mesh = io::load(input)?;
    out!("{}", mesh.content_hash());
    Ok(())
}

pub fn info(input: &Path, json: bool) -> anyhow::Result<()> {
    let mesh = io::load(input)?;
    let bbox = mesh.bounding_box();
    if json {
        let bbox = bbox.map(|(lo, hi)| serde_json::json!({ "min": lo, "max": hi }));
        let info = serde_json::json!({
            "vertices": mesh.vertex_count(),
            "triangles": mesh.triangle_count(),
            "bbox": bbox,
        });
        out!("{info}");
    } else {
        out!("vertices:  {}", mesh.vertex_count());
        out!("triangles: {}", mesh.triangle_count());
        match bbox {
            Some((lo, hi)) => out!("bbox:      {lo:?} .. {hi:?}"),
            None => out!("bbox:      (empty)"),
        }
    }
    Ok(())
}
