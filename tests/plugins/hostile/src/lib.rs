//! Test fixture: every way a plugin can misbehave. The host must stop each with a clear
//! error, within its limits, and stay usable for the next run.

use meshflow_plugin_sdk::{Mesh, Params, Result, Service, Value, ValueType};

fn loop_forever(_: &Mesh, _: &Params) -> Result<String> {
    let mut x = 0u64;
    loop {
        // Opaque to the optimiser, so the loop is really executed.
        x = std::hint::black_box(x.wrapping_add(1));
    }
}

fn allocate_forever(_: &Mesh, _: &Params) -> Result<String> {
    let mut hoard: Vec<Vec<u8>> = Vec::new();
    loop {
        hoard.push(vec![1u8; 16 << 20]);
        std::hint::black_box(&hoard);
    }
}

fn trap(_: &Mesh, _: &Params) -> Result<String> {
    std::process::abort()
}

fn trap_in_check(_: &Mesh, _: &Params) -> Result<Value> {
    std::process::abort()
}

fn panic(_: &Mesh, _: &Params) -> Result<String> {
    panic!("the hostile plugin panics on purpose")
}

/// Propagates the host's refusal of an edit that names a vertex that does not exist.
fn bad_edit(mesh: &Mesh, _: &Params) -> Result<String> {
    mesh.add_triangle([0, 1, 4_000_000_000])?;
    Ok("unreachable".into())
}

/// Tries every invalid edit, ignores the refusals, then makes one valid edit.
fn ignore_bad_edits(mesh: &Mesh, _: &Params) -> Result<String> {
    let n = mesh.vertex_slots() as u32;
    let refused = [
        mesh.add_triangle([0, 0, 1]).is_err(),
        mesh.add_vertex([f32::NAN, 0.0, 0.0]).is_err(),
        mesh.move_vertex(n, [0.0; 3]).is_err(),
        mesh.remove_triangles(&[0, 0]).is_err(),
        mesh.set_positions(&[1.0, 2.0]).is_err(),
        mesh.swap_edge(u32::MAX).is_err(),
        mesh.transform(&[f32::INFINITY; 12]).is_err(),
    ];
    if refused.iter().all(|&r| r) {
        mesh.flip_triangle(0)?;
        Ok("every invalid edit was refused".into())
    } else {
        Err(format!("some invalid edits were accepted: {refused:?}").into())
    }
}

/// Hands the host non-finite coordinates through every edit that carries one. The NaN has
/// a payload and the sign bit set: with NaN canonicalisation off it reaches the host as is.
fn non_finite_edits(mesh: &Mesh, _: &Params) -> Result<String> {
    let bad = [f32::from_bits(0xffc0_1234), f32::INFINITY, f32::NEG_INFINITY];
    let mut accepted = Vec::new();
    for value in bad {
        let p = [0.25, value, 0.25];
        let mut all = mesh.positions();
        all[1] = value;
        let mut matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        matrix[7] = value;
        let attempts = [
            ("add-vertex", mesh.add_vertex(p).is_ok()),
            ("add-vertices", mesh.add_vertices(&p).is_ok()),
            ("move-vertex", mesh.move_vertex(0, p).is_ok()),
            ("move-vertices", mesh.move_vertices(&[0], &p).is_ok()),
            ("set-positions", mesh.set_positions(&all).is_ok()),
            ("split-triangle-at", mesh.split_triangle_at(0, p).is_ok()),
            ("split-edge-at", mesh.split_edge_at(0, p).is_ok()),
            ("transform-component", mesh.transform_component(0, &matrix).is_ok()),
            ("transform", mesh.transform(&matrix).is_ok()),
        ];
        accepted.extend(attempts.iter().filter(|(_, ok)| *ok).map(|(name, _)| (*name, value)));
    }
    if accepted.is_empty() {
        Ok("every non-finite coordinate was refused".into())
    } else {
        Err(format!("non-finite coordinates were accepted: {accepted:?}").into())
    }
}

fn edit_forever(mesh: &Mesh, _: &Params) -> Result<String> {
    let chunk = vec![0.5f32; 3 << 16];
    loop {
        mesh.add_vertices(&chunk)?;
    }
}

fn print_forever(_: &Mesh, _: &Params) -> Result<String> {
    loop {
        println!("a plugin that never stops talking");
    }
}

fn edit_in_check(mesh: &Mesh, _: &Params) -> Result<Value> {
    mesh.flip_triangle(0)?;
    Ok(Value::Boolean(true))
}

/// A check that writes quality: the host refuses it (`read-only`), the value says how.
fn set_attribute_in_check(mesh: &Mesh, _: &Params) -> Result<Value> {
    let quality = vec![1.0; mesh.vertex_slots()];
    let refused = mesh.set_quality(None, &quality).expect_err("a check wrote quality");
    let removed = mesh.remove_attribute(meshflow_plugin_sdk::AttributeDomain::Vertex, "quality");
    Ok(Value::Text(format!("{refused} | {}", removed.expect_err("a check removed quality"))))
}

/// Adds a vertex and gives it no attribute values: the host's defaults, and its report.
fn add_bare_vertex(mesh: &Mesh, _: &Params) -> Result<String> {
    mesh.add_vertex([0.0, 0.0, 2.0])?;
    Ok("added a vertex".into())
}

/// Declares itself local, then adds a vertex: a partition's edits cannot be merged.
fn local_but_adds(mesh: &Mesh, _: &Params) -> Result<String> {
    mesh.add_vertex([0.0, 0.0, 2.0])?;
    Ok("added a vertex".into())
}

/// Declares a reach of one ring, then moves every vertex by an amount that depends on the
/// whole mesh (its vertex count): on partitions the result depends on the cut.
fn local_but_global(mesh: &Mesh, _: &Params) -> Result<String> {
    let shift = mesh.vertex_count() as f32 * 1e-3;
    let moved: Vec<f32> = mesh.positions().iter().map(|&c| c + shift).collect();
    mesh.set_positions(&moved)?;
    Ok(format!("moved by {shift}"))
}

fn one_ring(_: &Params) -> Result<u32> {
    Ok(1)
}

/// Declares blocks of 2,000 triangles, then moves every vertex, those the blocks share too.
fn blocks_but_moves_all(mesh: &Mesh, _: &Params) -> Result<String> {
    let moved: Vec<f32> = mesh.positions().iter().map(|&c| c + 1.0).collect();
    mesh.set_positions(&moved)?;
    Ok("moved every vertex".into())
}

fn small_blocks(_: &Params) -> Result<Option<u32>> {
    Ok(Some(2_000))
}

fn tiny_blocks(_: &Params) -> Result<Option<u32>> {
    Ok(Some(10))
}

fn wrong_result_type(_: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Text("not an integer".into()))
}

fn fail(_: &Mesh, _: &Params) -> Result<String> {
    Err("the input is not what this service wants".into())
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("loop-forever", "Never returns.", loop_forever),
        Service::filter("allocate-forever", "Allocates until stopped.", allocate_forever),
        Service::filter("trap", "Aborts.", trap),
        Service::filter("panic", "Panics.", panic),
        Service::filter("bad-edit", "Makes an invalid edit and propagates the error.", bad_edit),
        Service::filter(
            "ignore-bad-edits",
            "Makes invalid edits, then a valid one.",
            ignore_bad_edits,
        ),
        Service::filter(
            "non-finite-edits",
            "Tries non-finite coordinates in every edit that takes one.",
            non_finite_edits,
        ),
        Service::filter("edit-forever", "Adds vertices without end.", edit_forever),
        Service::filter("print-forever", "Prints without end.", print_forever),
        Service::filter("fail", "Returns an error.", fail),
        Service::check(
            "edit-in-check",
            "Edits although it is a check.",
            ValueType::Boolean,
            edit_in_check,
        ),
        Service::check(
            "set-attribute-in-check",
            "Writes and removes quality although it is a check; the refusals as its value.",
            ValueType::Text,
            set_attribute_in_check,
        ),
        Service::filter(
            "add-bare-vertex",
            "Adds a vertex without attribute values.",
            add_bare_vertex,
        ),
        Service::filter("local-but-adds", "Claims to be local, adds a vertex.", local_but_adds)
            .local(one_ring),
        Service::filter(
            "local-but-global",
            "Claims a reach of one ring, moves by the mesh's vertex count.",
            local_but_global,
        )
        .local(one_ring),
        Service::filter(
            "blocks-but-moves-all",
            "Declares blocks, then moves the vertices they share.",
            blocks_but_moves_all,
        )
        .blocks(small_blocks),
        Service::filter(
            "blocks-of-ten",
            "Declares blocks of ten triangles: a million sandboxes for a 10M mesh.",
            blocks_but_moves_all,
        )
        .blocks(tiny_blocks),
        Service::check(
            "trap-in-check",
            "Aborts although it is a check.",
            ValueType::Integer,
            trap_in_check,
        ),
        Service::check(
            "wrong-result-type",
            "Declares an integer, returns text.",
            ValueType::Integer,
            wrong_result_type,
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
