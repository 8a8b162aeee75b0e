//! Attributes through the SDK, natively: typed and generic reads and writes, a check that
//! may only read, and new vertices blended from their parents.

use meshflow_mesh::attributes::{Attribute, Domain, Values};
use meshflow_plugin_sdk::attributes::{COLOR, QUALITY};
use meshflow_plugin_sdk::native::{MeshData, run};
use meshflow_plugin_sdk::{
    AttributeDomain, AttributeValues, Mesh, NumberType, Params, Result, Service, Value, ValueType,
    blend_new_vertex_attributes,
};

/// A unit square of two triangles, coloured and with quality per vertex.
fn square() -> MeshData {
    let mut mesh = MeshData::new(
        vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
        vec![0, 1, 2, 0, 2, 3],
    );
    let rgba = vec![0, 0, 0, 255, 200, 0, 0, 255, 200, 100, 0, 255, 0, 100, 50, 255];
    mesh.attributes.insert(Attribute::color(rgba), 4, 2).unwrap();
    mesh.attributes.insert(Attribute::quality(vec![0.0, 1.0, 2.0, 3.0]), 4, 2).unwrap();
    mesh
}

fn read_and_rewrite(mesh: &Mesh, _: &Params) -> Result<String> {
    let colors = mesh.vertex_colors().ok_or("no colours")?;
    let quality = mesh.quality().ok_or("no quality")?;
    let doubled: Vec<f32> = quality.iter().map(|q| 2.0 * q).collect();
    mesh.set_quality(None, &doubled)?;
    mesh.set_vertex_colors(Some(&[1]), &[[1, 2, 3, 4]])?;
    mesh.set_attribute(
        AttributeDomain::Face,
        "label",
        1,
        None,
        &AttributeValues::S32(vec![-1, 7]),
    )?;
    let names: Vec<String> = mesh.attributes().into_iter().map(|a| a.name).collect();
    Ok(format!("{} colours, attributes {}", colors.len(), names.join(" ")))
}

fn quality_check(mesh: &Mesh, _: &Params) -> Result<Value> {
    let sum: f32 = mesh.quality().unwrap_or_default().iter().sum();
    mesh.set_quality(None, &[0.0; 4])?;
    Ok(Value::Real(f64::from(sum)))
}

fn quality_sum(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(mesh.quality().unwrap_or_default().iter().map(|&q| f64::from(q)).sum()))
}

/// Splits the square's diagonal by hand: a vertex at the middle from add-vertices, two new
/// triangles, and (unless `bare`) its values blended from the diagonal's ends; a second new
/// vertex blended from the first.
fn split_by_hand(mesh: &Mesh, blend: bool) -> Result<String> {
    let first = mesh.add_vertices(&[0.5, 0.5, 0.0, 0.75, 0.75, 0.0])?;
    mesh.remove_triangles(&[0, 1])?;
    mesh.add_triangles(&[0, 1, first, 1, 2, first, 2, 3, first, 3, 0, first])?;
    if blend {
        let written = blend_new_vertex_attributes(
            mesh,
            &[(first, vec![(0, 1.0), (2, 1.0)]), (first + 1, vec![(first, 0.5), (2, 0.5)])],
        )?;
        return Ok(format!("blended {written} attribute(s)"));
    }
    Ok("left the new vertices alone".into())
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("rewrite", "Reads and writes attributes.", read_and_rewrite),
        Service::check("sneaky-quality", "Writes quality.", ValueType::Real, quality_check),
        Service::check("quality-sum", "Sums quality.", ValueType::Real, quality_sum),
        Service::filter("split-blended", "Splits, blends.", |m, _| split_by_hand(m, true)),
        Service::filter("split-bare", "Splits.", |m, _| split_by_hand(m, false)),
    ]
}

#[test]
fn typed_and_generic_reads_and_writes_reach_the_mesh() {
    let out = run(&services(), "rewrite", square(), &[]).unwrap();
    assert_eq!(out.report, "4 colours, attributes color quality label");
    let a = &out.mesh.attributes;
    assert_eq!(a.get(Domain::Vertex, QUALITY).unwrap().values, Values::F32(vec![0., 2., 4., 6.]));
    let Values::U8(rgba) = &a.get(Domain::Vertex, COLOR).unwrap().values else { panic!() };
    assert_eq!(&rgba[4..8], &[1, 2, 3, 4]);
    assert_eq!(&rgba[..4], &[0, 0, 0, 255], "untouched vertices keep their colours");
    assert_eq!(a.get(Domain::Face, "label").unwrap().values, Values::I32(vec![-1, 7]));
}

#[test]
fn a_check_reads_attributes_but_may_not_set_them() {
    let error = run(&services(), "sneaky-quality", square(), &[]).unwrap_err();
    assert!(error.0.contains("read-only") && error.0.contains("set-attribute"), "{error}");
    let out = run(&services(), "quality-sum", square(), &[]).unwrap();
    assert!(matches!(out.value, Some(Value::Real(6.0))), "{:?}", out.value);
    let bare = MeshData::new(vec![0.0; 9], vec![0, 1, 2]);
    let out = run(&services(), "quality-sum", bare, &[]).unwrap();
    assert!(matches!(out.value, Some(Value::Real(0.0))), "{:?}", out.value);
}

#[test]
fn new_vertices_are_blended_from_their_parents_or_the_report_says_they_were_not() {
    let out = run(&services(), "split-blended", square(), &[]).unwrap();
    assert_eq!(out.report, "blended 2 attribute(s)");
    let a = &out.mesh.attributes;
    let Values::U8(rgba) = &a.get(Domain::Vertex, COLOR).unwrap().values else { panic!() };
    // Vertex 4 halfway between vertex 0 (0 0 0 255) and 2 (200 100 0 255); vertex 5
    // halfway between 4 and 2, from 4's rounded value.
    assert_eq!(&rgba[16..20], &[100, 50, 0, 255]);
    assert_eq!(&rgba[20..24], &[150, 75, 0, 255]);
    assert_eq!(
        a.get(Domain::Vertex, QUALITY).unwrap().values,
        Values::F32(vec![0.0, 1.0, 2.0, 3.0, 1.0, 1.5])
    );

    let out = run(&services(), "split-bare", square(), &[]).unwrap();
    assert_eq!(
        out.report,
        "left the new vertices alone\n2 new vertices took default colour, quality: the service \
         gave none"
    );
}

#[test]
fn blending_refuses_bad_weights_and_does_nothing_without_attributes() {
    fn bad(mesh: &Mesh, _: &Params) -> Result<String> {
        let v = mesh.add_vertex([0.5, 0.5, 0.0])?;
        blend_new_vertex_attributes(mesh, &[(v, [(0u32, -1.0), (1, 2.0)])])?;
        Ok(String::new())
    }
    fn none(mesh: &Mesh, _: &Params) -> Result<String> {
        let v = mesh.add_vertex([0.5, 0.5, 0.0])?;
        Ok(blend_new_vertex_attributes(mesh, &[(v, [(0u32, 1.0)])])?.to_string())
    }
    let services = vec![Service::filter("bad", "", bad), Service::filter("none", "", none)];
    let error = run(&services, "bad", square(), &[]).unwrap_err();
    assert!(error.0.contains("not negative"), "{error}");
    let bare = MeshData::new(vec![0.0; 9], vec![0, 1, 2]);
    let out = run(&services, "none", bare, &[]).unwrap();
    assert_eq!(out.report, "0", "no attribute, nothing written and nothing to report");
}

#[test]
fn values_round_as_the_host_rounds_them() {
    let mut v = AttributeValues::with_capacity(NumberType::U8, 2);
    v.push(254.5);
    v.push(-3.0);
    assert!(matches!(&v, AttributeValues::U8(b) if b == &[255, 0]), "{v:?}");
    let mut v = AttributeValues::S32(vec![0]);
    v.set(0, -2.5);
    assert_eq!(v.get(0), -3.0);
    assert_eq!(v.number_type(), NumberType::S32);
}
