//! Describing services and reading their parameters.

use crate::bindings::meshflow::geometry::types::{
    Outcome, Param, ParamInfo, ServiceInfo, ServiceKind, Value, ValueType,
};
use crate::{Error, Mesh, Result};

/// A filter edits the mesh and returns a short report of what it did.
pub type FilterFn = fn(&Mesh, &Params) -> Result<String>;
/// A check reads the mesh (the host refuses edits) and returns a value.
pub type CheckFn = fn(&Mesh, &Params) -> Result<Value>;
/// How many rings of the mesh around a vertex decide its new position, for given
/// parameters (see [`Service::local`]).
pub type ReachFn = fn(&Params) -> Result<u32>;
/// Above how many triangles a filter runs block by block, for given parameters; `None`:
/// whole with these parameters (see [`Service::blocks`]).
pub type BlocksFn = fn(&Params) -> Result<Option<u32>>;

enum Runner {
    Filter(FilterFn),
    Check(CheckFn),
}

/// One service of a plugin: its description and the function that runs it.
///
/// ```
/// use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service, Value, ValueType};
///
/// fn count(mesh: &Mesh, _: &Params) -> Result<Value> {
///     Ok(Value::Integer(mesh.vertex_count() as i64))
/// }
///
/// let service = Service::check("my-count", "Counts vertices.", ValueType::Integer, count)
///     .param(ParamSpec::integer("unused", 1).range(0.0, 10.0).doc("Shows a parameter."));
/// assert_eq!(service.name(), "my-count");
/// ```
pub struct Service {
    info: ServiceInfo,
    runner: Runner,
    reach: Option<ReachFn>,
    blocks: Option<BlocksFn>,
}

impl Service {
    pub fn filter(name: &str, doc: &str, run: FilterFn) -> Self {
        let info = info(name, doc, ServiceKind::Filter, None);
        Self { info, runner: Runner::Filter(run), reach: None, blocks: None }
    }

    pub fn check(name: &str, doc: &str, result: ValueType, run: CheckFn) -> Self {
        let info = info(name, doc, ServiceKind::Check, Some(result));
        Self { info, runner: Runner::Check(run), reach: None, blocks: None }
    }

    /// Declares a filter local: its result near a vertex depends only on the triangles
    /// around the vertices up to `reach(params) - 1` edges from it (and their vertices), read
    /// in ascending id order. For a filter that only moves vertices, a vertex's new position;
    /// for one that edits connectivity, every edit and whether it is made, around the
    /// vertices it changes (it may not add a vertex no triangle uses, nor make
    /// `set-positions`, transform, clear, component or attribute edits; see the WIT's
    /// `locality` interface). A host may then run it on partitions of a mesh too large for
    /// one sandbox, each grown by that many rings: the result must equal the whole-mesh
    /// run's bit for bit (hosts compare hashes, so a wrong claim shows). Laplacian
    /// smoothing with `k` iterations reaches `k` rings; degenerate-triangle repair two.
    ///
    /// ```
    /// use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service};
    ///
    /// fn smooth(_: &Mesh, _: &Params) -> Result<String> {
    ///     Ok(String::new())
    /// }
    /// fn rings(params: &Params) -> Result<u32> {
    ///     Ok(params.integer("iterations")? as u32)
    /// }
    /// let service = Service::filter("my-smoothing", "Smooths.", smooth)
    ///     .param(ParamSpec::integer("iterations", 1).range(1.0, 100.0))
    ///     .local(rings);
    /// assert!(service.is_local());
    /// ```
    pub fn local(mut self, reach: ReachFn) -> Self {
        self.reach = Some(reach);
        self
    }

    /// Whether [`Service::local`] declared it.
    pub fn is_local(&self) -> bool {
        self.reach.is_some()
    }

    /// Declares that on a mesh of more than `blocks(params)` triangles (when it gives
    /// `Some`) the filter's result is, by definition, its result on each block of about that
    /// many triangles run as a mesh of its own, the vertices blocks share kept where they
    /// are (the WIT's `blocks` interface); `Some(0)` runs it whole, as `None` does. Every
    /// host cuts the same blocks, so results agree across hosts, but not with a whole-mesh
    /// run: quadric decimation keeps the blocks' borders at full resolution. A filter that
    /// may move or remove its input's boundary vertices with these parameters must return
    /// `None`.
    ///
    /// ```
    /// use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service};
    ///
    /// fn simplify(_: &Mesh, _: &Params) -> Result<String> {
    ///     Ok(String::new())
    /// }
    /// /// Blocks of 4M triangles, unless told 0 (always whole).
    /// fn blocks(params: &Params) -> Result<Option<u32>> {
    ///     Ok(Some(params.integer("block-triangles")? as u32))
    /// }
    /// let service = Service::filter("my-simplify", "Simplifies.", simplify)
    ///     .param(ParamSpec::integer("block-triangles", 4_000_000).range(0.0, 4e9))
    ///     .blocks(blocks);
    /// assert_eq!(service.name(), "my-simplify");
    /// ```
    pub fn blocks(mut self, blocks: BlocksFn) -> Self {
        self.blocks = Some(blocks);
        self
    }

    pub fn param(mut self, param: ParamSpec) -> Self {
        self.info.params.push(param.0);
        self
    }

    pub fn name(&self) -> &str {
        &self.info.name
    }

    pub fn info(&self) -> &ServiceInfo {
        &self.info
    }

    fn run(&self, mesh: &Mesh, params: &Params) -> Result<Outcome> {
        Ok(match self.runner {
            Runner::Filter(run) => Outcome { value: None, report: run(mesh, params)? },
            Runner::Check(run) => {
                Outcome { value: Some(run(mesh, params)?), report: String::new() }
            }
        })
    }
}

fn info(name: &str, doc: &str, kind: ServiceKind, result: Option<ValueType>) -> ServiceInfo {
    ServiceInfo {
        name: name.into(),
        kind,
        doc: doc.into(),
        params: Vec::new(),
        result_type: result,
    }
}

/// A parameter declaration: name, type, default, and optionally range, choices and doc.
pub struct ParamSpec(ParamInfo);

impl ParamSpec {
    fn new(name: &str, ty: ValueType, default: Value) -> Self {
        ParamSpec(ParamInfo {
            name: name.into(),
            doc: String::new(),
            ty,
            default,
            min: None,
            max: None,
            choices: Vec::new(),
        })
    }

    pub fn integer(name: &str, default: i64) -> Self {
        Self::new(name, ValueType::Integer, Value::Integer(default))
    }

    pub fn real(name: &str, default: f64) -> Self {
        Self::new(name, ValueType::Real, Value::Real(default))
    }

    pub fn boolean(name: &str, default: bool) -> Self {
        Self::new(name, ValueType::Boolean, Value::Boolean(default))
    }

    /// A text parameter that must be one of `choices`.
    pub fn choice(name: &str, default: &str, choices: &[&str]) -> Self {
        let mut spec = Self::new(name, ValueType::Text, Value::Text(default.into()));
        spec.0.choices = choices.iter().map(|c| c.to_string()).collect();
        spec
    }

    /// Inclusive bounds for a numeric parameter; the host refuses values outside them.
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.0.min = Some(min);
        self.0.max = Some(max);
        self
    }

    pub fn doc(mut self, doc: &str) -> Self {
        self.0.doc = doc.into();
        self
    }
}

/// The parameters of one run. The host has checked them against the description and filled
/// in defaults, so a lookup only fails if the code asks for a parameter it did not declare.
pub struct Params(Vec<Param>);

impl Params {
    pub fn new(params: Vec<Param>) -> Self {
        Params(params)
    }

    fn get(&self, name: &str) -> Result<&Value> {
        self.0
            .iter()
            .find(|p| p.name == name)
            .map(|p| &p.value)
            .ok_or_else(|| Error(format!("parameter `{name}` was not given")))
    }

    pub fn integer(&self, name: &str) -> Result<i64> {
        match self.get(name)? {
            Value::Integer(v) => Ok(*v),
            other => Err(type_error(name, "an integer", other)),
        }
    }

    /// A real parameter; integers are accepted and widened.
    pub fn real(&self, name: &str) -> Result<f64> {
        match self.get(name)? {
            Value::Real(v) => Ok(*v),
            Value::Integer(v) => Ok(*v as f64),
            other => Err(type_error(name, "a real", other)),
        }
    }

    pub fn boolean(&self, name: &str) -> Result<bool> {
        match self.get(name)? {
            Value::Boolean(v) => Ok(*v),
            other => Err(type_error(name, "a boolean", other)),
        }
    }

    pub fn text(&self, name: &str) -> Result<&str> {
        match self.get(name)? {
            Value::Text(v) => Ok(v),
            other => Err(type_error(name, "a text", other)),
        }
    }
}

fn type_error(name: &str, expected: &str, got: &Value) -> Error {
    Error(format!("parameter `{name}` should be {expected}, got {got:?}"))
}

/// What the export macro calls: the description of every service.
pub fn describe(services: &[Service]) -> Vec<ServiceInfo> {
    services.iter().map(|s| s.info.clone()).collect()
}

/// What the export macro calls: runs the named service.
pub fn run(
    services: &[Service],
    name: &str,
    mesh: Mesh,
    params: Vec<Param>,
) -> std::result::Result<Outcome, String> {
    let service = services.iter().find(|s| s.info.name == name).ok_or_else(|| {
        let known: Vec<&str> = services.iter().map(|s| s.name()).collect();
        format!("unknown service `{name}`; this plugin has: {}", known.join(", "))
    })?;
    service.run(&mesh, &Params::new(params)).map_err(|e| e.0)
}

/// What the export macro calls: above how many triangles the named service runs block by
/// block with these parameters (`None` for one not declared [`Service::blocks`], one unknown,
/// parameters it refuses, or blocks of 0 triangles: whole, as the C++ and Python SDKs read it).
pub fn block_triangles(services: &[Service], name: &str, params: Vec<Param>) -> Option<u32> {
    let service = services.iter().find(|s| s.info.name == name)?;
    let blocks = service.blocks?;
    blocks(&Params::new(params)).ok().flatten().filter(|&n| n > 0)
}

/// What the export macro calls: how far the named service reaches with these parameters
/// (`None` for a service not declared [`Service::local`], or one unknown).
pub fn reach(services: &[Service], name: &str, params: Vec<Param>) -> Option<u32> {
    let service = services.iter().find(|s| s.info.name == name)?;
    let reach = service.reach?;
    reach(&Params::new(params)).ok()
}
