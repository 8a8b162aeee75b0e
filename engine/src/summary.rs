//! A batch's results table: one row per input from its run record.

use crate::record::{RunRecord, Status, SummaryRow};

/// The row of an input whose run ended (or is still going) as `record` says.
pub fn row(name: &str, record: &RunRecord) -> SummaryRow {
    let broadcast = record.broadcast.iter().flat_map(|b| &b.hosts).map(|h| h.bytes);
    let transfers = record.steps.iter().flat_map(|s| &s.transfers).map(|t| t.bytes);
    let mut checks = std::collections::BTreeMap::new();
    for step in record.steps.iter().filter(|s| s.kind == "check") {
        if let Some(value) = &step.value {
            checks.insert(check_column(&step.service, &step.path), value.clone());
        }
    }
    let status = serde_json::to_value(record.status).ok();
    SummaryRow {
        name: name.to_owned(),
        status: status.as_ref().and_then(|s| s.as_str()).unwrap_or("unknown").to_owned(),
        error: record.error.clone(),
        vertices_in: record.input.as_ref().map(|i| i.vertices),
        triangles_in: record.input.as_ref().map(|i| i.triangles),
        vertices_out: record.result.as_ref().map(|r| r.vertices),
        triangles_out: record.result.as_ref().map(|r| r.triangles),
        result_hash: (record.status == Status::Completed)
            .then(|| record.result.as_ref().map(|r| r.hash.clone()))
            .flatten(),
        total_seconds: record.total_ms.map(|ms| ms / 1e3),
        bytes_moved: broadcast.chain(transfers).sum(),
        checks,
    }
}

/// The row of an input that never became a run (unreadable, refused).
pub fn failed_row(name: &str, error: String) -> SummaryRow {
    SummaryRow {
        name: name.to_owned(),
        status: "failed".into(),
        error: Some(error),
        vertices_in: None,
        triangles_in: None,
        vertices_out: None,
        triangles_out: None,
        result_hash: None,
        total_seconds: None,
        bytes_moved: 0,
        checks: Default::default(),
    }
}

/// A check's column: the service, and where in the workflow it is (a workflow may use one
/// check twice). A WHILE's check runs each round; its row keeps the last value.
pub fn check_column(service: &str, path: &str) -> String {
    format!("{service} [{}]", path.trim_end_matches(".check"))
}

/// The fixed columns of a summary table, before one column per check.
pub const COLUMNS: [&str; 10] = [
    "name",
    "status",
    "error",
    "vertices_in",
    "triangles_in",
    "vertices_out",
    "triangles_out",
    "result_hash",
    "total_seconds",
    "bytes_moved",
];

/// Every check column of `rows`, in order of first appearance.
pub fn check_columns(rows: &[SummaryRow]) -> Vec<String> {
    let mut columns: Vec<String> = Vec::new();
    for name in rows.iter().flat_map(|r| r.checks.keys()) {
        if !columns.contains(name) {
            columns.push(name.clone());
        }
    }
    columns
}

/// A row's cells in the order of [`COLUMNS`] and then `checks`; absent values are empty.
pub fn cells(row: &SummaryRow, checks: &[String]) -> Vec<String> {
    let text = |v: Option<String>| v.unwrap_or_default();
    let number = |v: Option<u64>| v.map(|n| n.to_string()).unwrap_or_default();
    let mut cells = vec![
        row.name.clone(),
        row.status.clone(),
        text(row.error.clone()),
        number(row.vertices_in),
        number(row.triangles_in),
        number(row.vertices_out),
        number(row.triangles_out),
        text(row.result_hash.clone()),
        row.total_seconds.map(|s| format!("{s:.3}")).unwrap_or_default(),
        row.bytes_moved.to_string(),
    ];
    cells.extend(checks.iter().map(|c| match row.checks.get(c) {
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(value) => value.to_string(),
        None => String::new(),
    }));
    cells
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    #[test]
    fn a_row_keeps_the_last_value_of_each_check_and_counts_every_byte_moved() {
        let record: RunRecord = serde_json::from_value(json!({
            "id": "r-1", "status": "completed", "error": null, "warnings": [], "transfer": "auto",
            "input": {"url": "u", "hash": "h0", "vertices": 10, "triangles": 16},
            "broadcast": {"ms": 1.0, "hosts": [{"host": "a", "bytes": 100, "download_ms": 1.0, "load_ms": 1.0},
                                               {"host": "b", "bytes": 100, "download_ms": 1.0, "load_ms": 1.0}]},
            "steps": [
                step(0, "steps[0].while.check", "check", json!(3), vec![]),
                step(1, "steps[0].do[0]", "filter", json!(null), vec![json!({"host": "b", "via": "correction", "bytes": 7,
                    "download_ms": 0.0, "apply_ms": 0.0, "started_ms": 0.0, "finished_ms": 0.0, "fallback": null, "error": null})]),
                step(2, "steps[0].while.check", "check", json!(0), vec![]),
            ],
            "result": {"url": "r", "hash": "h1", "bytes": 5, "vertices": 9, "triangles": 14},
            "total_ms": 1500.0
        }))
        .unwrap();
        let row = row("scan.ply", &record);
        assert_eq!(
            (row.vertices_in, row.vertices_out, row.triangles_out),
            (Some(10), Some(9), Some(14))
        );
        assert_eq!((row.bytes_moved, row.total_seconds), (207, Some(1.5)));
        assert_eq!(row.result_hash.as_deref(), Some("h1"));
        let column = "hole-count [steps[0].while]";
        assert_eq!(row.checks.get(column), Some(&json!(0)));
        let checks = check_columns(std::slice::from_ref(&row));
        assert_eq!(checks, [column]);
        let cells = cells(&row, &checks);
        assert_eq!(cells.len(), COLUMNS.len() + 1);
        assert_eq!(
            (cells[1].as_str(), cells[8].as_str(), cells[10].as_str()),
            ("completed", "1.500", "0")
        );
    }

    fn step(
        index: usize,
        path: &str,
        kind: &str,
        value: serde_json::Value,
        transfers: Vec<serde_json::Value>,
    ) -> serde_json::Value {
        let service = if kind == "check" { "hole-count" } else { "fill-holes" };
        json!({"index": index, "path": path, "kind": kind, "service": service, "host": "a",
               "plugin": "p", "params": {}, "started_ms": 0.0, "finished_ms": 0.0, "compute_ms": 0.0,
               "wait_ms": 0.0, "overhead_ms": 0.0, "input_hash": "h", "output_hash": null,
               "vertices": null, "triangles": null, "edits": null, "correction_bytes": null,
               "full_bytes": null, "value": value, "condition": null, "report": "",
               "failed_hosts": [], "transfers": transfers})
    }
}
