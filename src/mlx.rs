//! MeshLab filter scripts (`.mlx`, as MeshLab's "Save filter script" and pymeshlab's
//! `MeshSet.save_filter_script` write them) to workflows and back, for the filters that
//! have an equivalent service. The table [`MAPPINGS`] says how each parameter converts.
//!
//! A script is `<FilterScript>` with one `<filter name="…">` per step, each with
//! `<Param name type value [min max]/>`. MeshLab's `RichAbsPerc` values are absolute
//! lengths with `max` the bounding-box diagonal of the mesh the script was made on; the
//! services take percentages of the diagonal, so `value / max * 100` (and back, given the
//! diagonal of a mesh).

use serde_json::{Map, Value as Json, json};

/// The largest script read, and the most filters in one.
pub const MAX_SCRIPT_BYTES: usize = 1 << 20;
pub const MAX_FILTERS: usize = 1000;

/// How one MeshLab parameter becomes a service parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Conversion {
    /// The same number or boolean.
    Same,
    /// An absolute length (`RichAbsPerc`) as a percentage of the bounding-box diagonal.
    PercentOfDiagonal,
    /// A boolean choosing between two texts: (when true, when false).
    Choice(&'static str, &'static str),
}

#[derive(Debug, Clone, Copy)]
pub struct ParamMapping {
    /// MeshLab's name (`stepSmoothNum`) and type (`RichInt`).
    pub meshlab: &'static str,
    pub meshlab_type: &'static str,
    /// The service's parameter.
    pub param: &'static str,
    pub conversion: Conversion,
    /// Left out when zero (MeshLab's "0: not used", as decimation's `TargetPerc`).
    pub zero_means_unset: bool,
}

/// One MeshLab filter and the service that does its job.
#[derive(Debug, Clone, Copy)]
pub struct Mapping {
    pub service: &'static str,
    /// MeshLab's filter name, as scripts carry it.
    pub filter: &'static str,
    pub params: &'static [ParamMapping],
    /// What differs from MeshLab, for the user.
    pub note: &'static str,
}

const fn same(
    meshlab: &'static str,
    meshlab_type: &'static str,
    param: &'static str,
) -> ParamMapping {
    ParamMapping {
        meshlab,
        meshlab_type,
        param,
        conversion: Conversion::Same,
        zero_means_unset: false,
    }
}

/// Every filter mapped, keyed by service; a service's first row is what `to-mlx` writes.
/// Rows for services being written elsewhere (decimation, remeshing, Loop, Taubin,
/// non-manifold repair, orientation) use the parameter names of their issue (18), and
/// convert once those services are on offer.
pub const MAPPINGS: &[Mapping] = &[
    Mapping {
        service: "remove-smallest-components",
        filter: "Remove Isolated pieces (wrt Face Num.)",
        params: &[same("MinComponentSize", "RichInt", "min-triangles")],
        note: "removes components with fewer triangles than MinComponentSize, as MeshLab does",
    },
    Mapping {
        service: "laplacian-smoothing",
        filter: "Laplacian Smooth",
        params: &[
            same("stepSmoothNum", "RichInt", "iterations"),
            same("Boundary", "RichBool", "keep-boundary"),
            ParamMapping {
                meshlab: "cotangentWeight",
                meshlab_type: "RichBool",
                param: "weights",
                conversion: Conversion::Choice("cotangent", "uniform"),
                zero_means_unset: false,
            },
        ],
        note: "MeshLab's Boundary smooths boundary vertices along the boundary; keep-boundary \
               holds them fixed",
    },
    Mapping {
        service: "fill-holes",
        filter: "Close Holes",
        params: &[
            same("MaxHoleSize", "RichInt", "max-hole-edges"),
            same("RefineHole", "RichBool", "refine"),
        ],
        note: "MaxHoleSize counts boundary edges, as max-hole-edges does",
    },
    Mapping {
        service: "remove-degenerate-triangles",
        filter: "Remove Zero Area Faces",
        params: &[],
        note: "also repairs caps and needles and removes duplicate triangles",
    },
    Mapping {
        service: "remove-degenerate-triangles",
        filter: "Remove Duplicate Faces",
        params: &[],
        note: "removes duplicate triangles and zero-area ones",
    },
    Mapping {
        service: "taubin-smoothing",
        filter: "Taubin Smooth",
        params: &[
            same("lambda", "RichFloat", "lambda"),
            same("mu", "RichFloat", "mu"),
            same("stepSmoothNum", "RichInt", "iterations"),
        ],
        note: "",
    },
    Mapping {
        service: "quadric-decimation",
        filter: "Simplification: Quadric Edge Collapse Decimation",
        params: &[
            same("TargetFaceNum", "RichInt", "target-triangles"),
            ParamMapping {
                meshlab: "TargetPerc",
                meshlab_type: "RichFloat",
                param: "target-ratio",
                conversion: Conversion::Same,
                zero_means_unset: true,
            },
        ],
        note: "a non-zero TargetPerc wins over TargetFaceNum, as in MeshLab; boundary and \
               topology are always preserved",
    },
    Mapping {
        service: "isotropic-remeshing",
        filter: "Remeshing: Isotropic Explicit Remeshing",
        params: &[
            ParamMapping {
                meshlab: "TargetLen",
                meshlab_type: "RichAbsPerc",
                param: "target-edge-length",
                conversion: Conversion::PercentOfDiagonal,
                zero_means_unset: false,
            },
            same("Iterations", "RichInt", "iterations"),
        ],
        note: "TargetLen (absolute) becomes a percentage of the bounding-box diagonal",
    },
    Mapping {
        service: "loop-subdivision",
        filter: "Subdivision Surfaces: Loop",
        params: &[same("Iterations", "RichInt", "iterations")],
        note: "every edge is refined (MeshLab's edge Threshold is not used)",
    },
    Mapping {
        service: "repair-non-manifold",
        filter: "Repair non Manifold Edges",
        params: &[],
        note: "also splits non-manifold vertices",
    },
    Mapping {
        service: "repair-non-manifold",
        filter: "Repair non Manifold Vertices by splitting",
        params: &[],
        note: "also repairs non-manifold edges",
    },
    Mapping {
        service: "orient-consistently",
        filter: "Re-Orient all faces coherently",
        params: &[],
        note: "closed components face outward",
    },
];

/// MeshLab parameters that change nothing meshflow does when they have these values
/// (selections are MeshLab's; meshflow filters work on the whole mesh).
const HARMLESS: &[(&str, &str)] = &[
    ("Selected", "false"),
    ("SelectedOnly", "false"),
    ("NewFaceSelected", "false"),
    ("NewFaceSelected", "true"),
];

/// A script converted: the workflow, and what the user should know.
#[derive(Debug)]
pub struct FromMlx {
    pub workflow: Json,
    /// Parameters left out, per filter, and the mappings' notes.
    pub notes: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum MlxError {
    #[error("not a MeshLab filter script: {0}")]
    Malformed(String),
    #[error("the script is {0} bytes; at most {MAX_SCRIPT_BYTES} are read")]
    TooLarge(usize),
    #[error("the script has {0} filters; at most {MAX_FILTERS}")]
    TooManyFilters(usize),
    #[error("no filter in the script maps to a meshflow service")]
    Empty,
    /// Every filter that could not be mapped, each with why.
    #[error("{} filter(s) have no meshflow equivalent:\n{}", .0.len(), .0.join("\n"))]
    Unmapped(Vec<String>),
    #[error("steps[{index}] ({service}): {message}")]
    NotConvertible { index: usize, service: String, message: String },
}

/// Reads a script; every filter must map (else [`MlxError::Unmapped`] lists each that
/// does not, with its position and why).
pub fn from_mlx(text: &str) -> Result<FromMlx, MlxError> {
    if text.len() > MAX_SCRIPT_BYTES {
        return Err(MlxError::TooLarge(text.len()));
    }
    // MeshLab writes `<!DOCTYPE FilterScript>`; roxmltree bounds entity expansion.
    let options = roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
    let document = roxmltree::Document::parse_with_options(text, options)
        .map_err(|e| MlxError::Malformed(e.to_string()))?;
    let root = document.root_element();
    if root.tag_name().name() != "FilterScript" {
        return Err(MlxError::Malformed(format!(
            "the root is <{}>, not <FilterScript>",
            root.tag_name().name()
        )));
    }
    let filters: Vec<_> = root.children().filter(|n| n.is_element()).collect();
    if filters.len() > MAX_FILTERS {
        return Err(MlxError::TooManyFilters(filters.len()));
    }
    let (mut steps, mut notes, mut unmapped) = (Vec::new(), Vec::new(), Vec::new());
    for (index, filter) in filters.iter().enumerate() {
        let name = filter.attribute("name").unwrap_or("");
        if filter.tag_name().name() != "filter" {
            let tag = filter.tag_name().name();
            unmapped.push(format!(
                "  filter {index}: <{tag}> is not a <filter> (MeshLab XML filters are not read)"
            ));
            continue;
        }
        let Some(mapping) = MAPPINGS.iter().find(|m| m.filter.eq_ignore_ascii_case(name)) else {
            unmapped.push(format!("  filter {index}: \"{name}\": no meshflow service does this"));
            continue;
        };
        let given: Vec<(&str, &str, Option<&str>)> = filter
            .children()
            .filter(|n| n.has_tag_name("Param"))
            .map(|p| {
                (
                    p.attribute("name").unwrap_or(""),
                    p.attribute("value").unwrap_or(""),
                    p.attribute("max"),
                )
            })
            .collect();
        match convert_params(mapping, &given) {
            Ok((params, ignored)) => {
                let mut step = json!({"run": mapping.service});
                if !params.is_empty() {
                    step["params"] = Json::Object(params);
                }
                steps.push(step);
                if !ignored.is_empty() {
                    notes
                        .push(format!("filter {index} ({name}): not used: {}", ignored.join(", ")));
                }
                if !mapping.note.is_empty() {
                    notes.push(format!(
                        "filter {index} ({name}) -> {}: {}",
                        mapping.service, mapping.note
                    ));
                }
            }
            Err(why) => unmapped.push(format!("  filter {index}: \"{name}\": {why}")),
        }
    }
    if !unmapped.is_empty() {
        return Err(MlxError::Unmapped(unmapped));
    }
    if steps.is_empty() {
        return Err(MlxError::Empty);
    }
    Ok(FromMlx { workflow: json!({"steps": steps}), notes })
}

/// Why one filter's parameter keeps the filter from converting.
#[derive(Debug, thiserror::Error)]
enum ParamRefusal {
    #[error("{0}=true works on a selection; meshflow filters the whole mesh")]
    Selection(String),
    #[error("{name}: \"{value}\" is not a {expected}")]
    NotA { name: String, value: String, expected: &'static str },
    #[error("{name}: \"{value}\" is not true or false")]
    NotBool { name: String, value: String },
    #[error("{0} has no bounding-box diagonal (max) to make it a percentage")]
    NoDiagonal(String),
}

/// The service parameters of one filter, and the MeshLab parameters left out.
fn convert_params(
    mapping: &Mapping,
    given: &[(&str, &str, Option<&str>)],
) -> Result<(Map<String, Json>, Vec<String>), ParamRefusal> {
    let not_a = |name: &str, value: &str, expected: &'static str| ParamRefusal::NotA {
        name: name.into(),
        value: value.into(),
        expected,
    };
    let mut params = Map::new();
    let mut ignored = Vec::new();
    for &(name, value, max) in given {
        let Some(spec) = mapping.params.iter().find(|p| p.meshlab == name) else {
            if name.starts_with("Selected") && value == "true" {
                return Err(ParamRefusal::Selection(name.into()));
            }
            if !HARMLESS.iter().any(|&(n, v)| n == name && v == value) {
                ignored.push(format!("{name}={value}"));
            }
            continue;
        };
        let converted = match spec.conversion {
            Conversion::Same => scalar(spec.meshlab_type, value)
                .ok_or_else(|| not_a(name, value, spec.meshlab_type))?,
            Conversion::Choice(yes, no) => match value {
                "true" => yes.into(),
                "false" => no.into(),
                other => {
                    return Err(ParamRefusal::NotBool { name: name.into(), value: other.into() });
                }
            },
            Conversion::PercentOfDiagonal => {
                let absolute: f64 = value.parse().map_err(|_| not_a(name, value, "number"))?;
                let diagonal: f64 = max
                    .and_then(|m| m.parse().ok())
                    .filter(|d: &f64| d.is_finite() && *d > 0.0)
                    .ok_or_else(|| ParamRefusal::NoDiagonal(name.into()))?;
                json!(round6(absolute / diagonal * 100.0))
            }
        };
        if spec.zero_means_unset && converted.as_f64() == Some(0.0) {
            continue;
        }
        params.insert(spec.param.into(), converted);
    }
    // A decimation ratio wins over a face count, as in MeshLab.
    if params.contains_key("target-ratio") {
        params.remove("target-triangles");
    }
    Ok((params, ignored))
}

/// Six decimals: MeshLab writes about six significant digits, so more would be noise.
fn round6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

fn scalar(meshlab_type: &str, value: &str) -> Option<Json> {
    match meshlab_type {
        "RichBool" => value.parse::<bool>().ok().map(Json::from),
        "RichInt" => value.parse::<i64>().ok().map(Json::from),
        _ => value.parse::<f64>().ok().filter(|x| x.is_finite()).map(Json::from),
    }
}

/// Writes a workflow without IF or WHILE as a script. `diagonal` (of the mesh it will run
/// on) is needed only for parameters MeshLab takes as absolute lengths.
pub fn to_mlx(workflow: &Json, diagonal: Option<f64>) -> Result<String, MlxError> {
    let steps = match workflow {
        Json::Array(steps) => steps,
        Json::Object(object) => object
            .get("steps")
            .and_then(Json::as_array)
            .ok_or_else(|| MlxError::Malformed("the workflow has no \"steps\"".into()))?,
        _ => return Err(MlxError::Malformed("a workflow is an object or a list of steps".into())),
    };
    let mut out = String::from("<!DOCTYPE FilterScript>\n<FilterScript>\n");
    let mut unmapped = Vec::new();
    for (index, step) in steps.iter().enumerate() {
        let Some(service) = step.get("run").and_then(Json::as_str) else {
            unmapped.push(format!("  steps[{index}]: IF and WHILE have no MeshLab equivalent"));
            continue;
        };
        let Some(mapping) = MAPPINGS.iter().find(|m| m.service == service) else {
            unmapped.push(format!("  steps[{index}]: no MeshLab filter does \"{service}\""));
            continue;
        };
        let empty = Map::new();
        let params = step.get("params").and_then(Json::as_object).unwrap_or(&empty);
        let fail =
            |message: String| MlxError::NotConvertible { index, service: service.into(), message };
        if let Some(extra) =
            params.keys().find(|k| !mapping.params.iter().any(|p| p.param == k.as_str()))
        {
            return Err(fail(format!("parameter `{extra}` has no MeshLab equivalent")));
        }
        out.push_str(&format!(" <filter name=\"{}\">\n", escape(mapping.filter)));
        for spec in mapping.params {
            let Some(value) = params.get(spec.param) else { continue };
            let text = match (spec.conversion, value) {
                (Conversion::Same, Json::Bool(b)) => b.to_string(),
                (Conversion::Same, Json::Number(n)) => n.to_string(),
                (Conversion::Choice(yes, no), Json::String(s)) if s == yes || s == no => {
                    (s == yes).to_string()
                }
                (Conversion::PercentOfDiagonal, Json::Number(n)) => {
                    let diagonal = diagonal.ok_or_else(|| {
                        fail(format!(
                            "`{}` is a percentage of the bounding-box diagonal and MeshLab's {} is absolute: \
                             give the mesh the script is for",
                            spec.param, spec.meshlab
                        ))
                    })?;
                    // Full precision both ways, so reading it back gives the same percentage.
                    let absolute = n.as_f64().unwrap_or(0.0) / 100.0 * diagonal;
                    out.push_str(&format!(
                        "  <Param name=\"{}\" type=\"{}\" value=\"{absolute}\" min=\"0\" max=\"{diagonal}\"/>\n",
                        spec.meshlab, spec.meshlab_type
                    ));
                    continue;
                }
                (_, other) => {
                    return Err(fail(format!(
                        "`{}` = {other} cannot be written for MeshLab",
                        spec.param
                    )));
                }
            };
            out.push_str(&format!(
                "  <Param name=\"{}\" type=\"{}\" value=\"{}\"/>\n",
                spec.meshlab,
                spec.meshlab_type,
                escape(&text)
            ));
        }
        out.push_str(" </filter>\n");
    }
    if !unmapped.is_empty() {
        return Err(MlxError::Unmapped(unmapped));
    }
    out.push_str("</FilterScript>\n");
    Ok(out)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written the way MeshLab 2023.12 / pymeshlab's `save_filter_script` write scripts
    /// (attribute order, descriptions, tooltips, `isxmlparam`); pymeshlab is not needed.
    const SAVED_BY_PYMESHLAB: &str = include_str!("../tests/data/pymeshlab-repair.mlx");

    #[test]
    fn a_saved_script_becomes_a_workflow_with_converted_parameters() {
        let converted = from_mlx(SAVED_BY_PYMESHLAB).unwrap();
        assert_eq!(
            converted.workflow,
            json!({"steps": [
                {"run": "remove-smallest-components", "params": {"min-triangles": 25}},
                {"run": "laplacian-smoothing", "params": {"iterations": 3, "keep-boundary": true, "weights": "cotangent"}},
                {"run": "fill-holes", "params": {"max-hole-edges": 30}},
                {"run": "remove-degenerate-triangles"},
                {"run": "quadric-decimation", "params": {"target-ratio": 0.5}},
                {"run": "isotropic-remeshing", "params": {"target-edge-length": 1.0, "iterations": 3}},
                {"run": "taubin-smoothing", "params": {"lambda": 0.5, "mu": -0.53, "iterations": 10}},
                {"run": "loop-subdivision", "params": {"iterations": 1}},
                {"run": "repair-non-manifold"},
                {"run": "orient-consistently"}
            ]})
        );
        assert!(
            converted.notes.iter().any(|n| n.contains("QualityThr=0.3")),
            "{:?}",
            converted.notes
        );
    }

    #[test]
    fn every_mapped_filter_round_trips() {
        let workflow = from_mlx(SAVED_BY_PYMESHLAB).unwrap().workflow;
        let diagonal = 2.0 * 3f64.sqrt();
        let script = to_mlx(&workflow, Some(diagonal)).unwrap();
        assert_eq!(from_mlx(&script).unwrap().workflow, workflow);
        // Every service of the table writes and reads back as itself.
        for mapping in MAPPINGS {
            let step = json!({"steps": [{"run": mapping.service}]});
            assert_eq!(
                from_mlx(&to_mlx(&step, None).unwrap()).unwrap().workflow,
                step,
                "{}",
                mapping.service
            );
        }
    }

    #[test]
    fn filters_without_an_equivalent_are_refused_each_by_name() {
        let script = r#"<!DOCTYPE FilterScript>
<FilterScript>
 <filter name="Laplacian Smooth"><Param name="stepSmoothNum" type="RichInt" value="2"/></filter>
 <filter name="Surface Reconstruction: Screened Poisson"/>
 <filter name="Close Holes"><Param name="MaxHoleSize" type="RichInt" value="30"/><Param name="Selected" type="RichBool" value="true"/></filter>
 <filter name="Remove Isolated pieces (wrt Diameter)"/>
</FilterScript>"#;
        let MlxError::Unmapped(refused) = from_mlx(script).unwrap_err() else { panic!() };
        assert_eq!(refused.len(), 3, "{refused:?}");
        assert!(refused[0].contains("filter 1: \"Surface Reconstruction: Screened Poisson\""));
        assert!(refused[1].contains("filter 2: \"Close Holes\": Selected=true"));
        assert!(refused[2].contains("filter 3: \"Remove Isolated pieces (wrt Diameter)\""));
        assert!(matches!(from_mlx("<FilterScript><filter"), Err(MlxError::Malformed(_))));
        assert!(matches!(from_mlx("<Other/>"), Err(MlxError::Malformed(_))));
    }

    #[test]
    fn workflows_with_branches_or_unmapped_parameters_are_not_written() {
        let branching = json!([{"while": {"check": "hole-count", "op": ">", "value": 0}, "do": [{"run": "fill-holes"}]}]);
        assert!(matches!(to_mlx(&branching, None), Err(MlxError::Unmapped(_))));
        let seeded =
            json!([{"run": "laplacian-smoothing", "params": {"iterations": 2, "seed": 1}}]);
        assert!(to_mlx(&seeded, None).unwrap_err().to_string().contains("`seed`"));
        let relative =
            json!([{"run": "isotropic-remeshing", "params": {"target-edge-length": 1.0}}]);
        assert!(to_mlx(&relative, None).unwrap_err().to_string().contains("percentage"));
    }
}
