//! Attribute ops in a correction.
//!
//! ops section: domain, name (length, bytes); for a `set-attribute` also the number type,
//! components, whether ids follow, the predictor and the decorrelated components. ids
//! section: the ids. geometry section: the values, each an exact residual from its
//! prediction ([`numbers`](super::coding::numbers), models kept per number type and
//! component count across the correction's ops). The encoder picks the predictor whose
//! residuals are smallest:
//! - the element's value before the op (a filter that adjusts a quality), or `a x + b` of
//!   it, `a` and `b` fitted to the op and sent with it (a quality rescaled);
//! - the value before it in the op (new vertices blended from their neighbours come in the
//!   order they were made, close together);
//! - for a set of every vertex slot, a packed mesh's predictors with the vertices in id order
//!   (`pack/values.rs`): the mean of the new values of its neighbours with lower ids, their
//!   parallelograms, the geometry's normal (a quality or colour computed from the surface,
//!   normals a service computed);
//! - zero.

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, Domain, MAX_NAME_BYTES, NumberType, Values};
use meshflow_mesh::store::{MeshStore, Op, OpKind};
use meshflow_topology::VertexTriangles;

use super::coding::model::AdaptiveModel;
use super::coding::numbers::{
    Costs, MAX_COMPONENTS, Number, ValueModels, adjusted, difference, zigzag,
};
use super::coding::stream::{CorruptStream, SymbolReader, SymbolWriter};
use super::lists::IdListCoder;
use crate::pack::values::{Geometry, Predictions, Predictor as MeshPredictor};

const DOMAINS: [Domain; 3] = [Domain::Vertex, Domain::Face, Domain::Corner];
/// Values the encoder's choice of predictor looks at, at most.
const SAMPLE: usize = 1 << 16;

/// What predicts a `set-attribute`'s values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Predictor {
    /// The element's value before the op.
    Current,
    /// `a x + b` of the element's value `x` before the op, `a` and `b` fitted to the op and
    /// sent: a quality rescaled, a colour brightened.
    Scaled,
    Previous,
    Zero,
    /// For a set of every vertex slot: a packed mesh's predictor, the vertices in id order.
    Mesh(MeshPredictor),
}

/// The packed mesh's predictors a set of every vertex may use, after the three of its own.
const MESH_PREDICTORS: [MeshPredictor; 4] = [
    MeshPredictor::Neighbours,
    MeshPredictor::Parallelogram,
    MeshPredictor::Normal,
    MeshPredictor::AngleNormal,
];

impl Predictor {
    fn symbol(self) -> usize {
        match self {
            Predictor::Current => 0,
            Predictor::Previous => 1,
            Predictor::Zero => 2,
            Predictor::Scaled => 3,
            Predictor::Mesh(p) => {
                4 + MESH_PREDICTORS.iter().position(|&q| q == p).expect("only these")
            }
        }
    }

    fn from_symbol(symbol: usize) -> Self {
        match symbol {
            0 => Predictor::Current,
            1 => Predictor::Previous,
            2 => Predictor::Zero,
            3 => Predictor::Scaled,
            s => Predictor::Mesh(MESH_PREDICTORS[s - 4]),
        }
    }
}

const PREDICTOR_SYMBOLS: usize = 4 + MESH_PREDICTORS.len();

pub(super) struct AttributeCoder {
    domain: AdaptiveModel,
    number_type: AdaptiveModel,
    components: AdaptiveModel,
    name_byte: AdaptiveModel,
    has_ids: AdaptiveModel,
    predictor: AdaptiveModel,
    /// Bits 1 to 3 of the decorrelation mask, shifted down.
    decorrelate: AdaptiveModel,
    /// Per number type and component count, created when first used.
    values: Vec<Option<ValueModels>>,
}

impl AttributeCoder {
    pub(super) fn new() -> Self {
        Self {
            domain: AdaptiveModel::new(DOMAINS.len()),
            number_type: AdaptiveModel::new(NumberType::ALL.len()),
            components: AdaptiveModel::new(MAX_COMPONENTS + 1),
            name_byte: AdaptiveModel::new(256),
            has_ids: AdaptiveModel::new(2),
            predictor: AdaptiveModel::new(PREDICTOR_SYMBOLS),
            decorrelate: AdaptiveModel::new(8),
            values: (0..NumberType::ALL.len() * MAX_COMPONENTS).map(|_| None).collect(),
        }
    }

    fn header(&mut self, w: &mut SymbolWriter, domain: Domain, name: &str) {
        w.symbol(
            &mut self.domain,
            DOMAINS.iter().position(|&d| d == domain).expect("every domain"),
        );
        w.symbol(&mut self.name_byte, name.len());
        for &b in name.as_bytes() {
            w.symbol(&mut self.name_byte, usize::from(b));
        }
    }

    fn read_header(&mut self, r: &mut SymbolReader) -> Result<(Domain, String), CorruptStream> {
        let domain = DOMAINS[r.symbol(&mut self.domain)?];
        let len = r.symbol(&mut self.name_byte)?;
        if len > MAX_NAME_BYTES {
            return Err(CorruptStream);
        }
        let bytes = (0..len)
            .map(|_| r.symbol(&mut self.name_byte).map(|b| b as u8))
            .collect::<Result<Vec<u8>, _>>()?;
        Ok((domain, String::from_utf8(bytes).map_err(|_| CorruptStream)?))
    }

    /// The models of `ty` with `components`, fresh the first time.
    fn models<T: Number>(&mut self, ty: NumberType, components: usize) -> &mut ValueModels {
        let slot = type_index(ty) * MAX_COMPONENTS + components - 1;
        self.values[slot].get_or_insert_with(|| ValueModels::new::<T>(components, 0))
    }

    /// Codes a `set-attribute` or `remove-attribute` (any other op is not this coder's)
    /// against `store`, the state before it.
    pub(super) fn write(
        &mut self,
        out: [&mut SymbolWriter; 3],
        lists: &mut IdListCoder,
        store: &MeshStore,
        op: &Op,
    ) {
        let [ops, ids_out, geometry] = out;
        match op {
            Op::RemoveAttribute { domain, name } => self.header(ops, *domain, name),
            Op::SetAttribute { domain, name, components, ids, values } => {
                self.header(ops, *domain, name);
                let ty = values.number_type();
                ops.symbol(&mut self.number_type, type_index(ty));
                ops.symbol(&mut self.components, usize::from(*components));
                ops.bit(&mut self.has_ids, ids.is_some());
                if let Some(ids) = ids {
                    lists.write(ids_out, ids);
                }
                let n = usize::from(*components);
                if !(1..=MAX_COMPONENTS).contains(&n) || values.len() % n != 0 {
                    return; // the store refuses it
                }
                let slots = store.shared_slots();
                let whole = Whole::new(&slots, *domain, ids.is_none());
                let mesh = whole.as_ref().map(|w| w.geometry(&slots));
                let mut context = Context::new(&slots, (*domain, name, n), ids.as_deref(), &mesh);
                let float = matches!(ty, NumberType::F32 | NumberType::F64);
                macro_rules! typed {
                    ($v:expr, $t:ty) => {{
                        context.scale = context.fit($v);
                        let choice = choose::<$t>(&context, float, $v);
                        ops.symbol(&mut self.predictor, choice.0.symbol());
                        ops.symbol(&mut self.decorrelate, usize::from(choice.1 >> 1));
                        if choice.0 == Predictor::Scaled {
                            let (a, b) = context.scale.expect("chosen only when fitted");
                            for x in [a, b].map(f64::to_bits) {
                                geometry.raw(32, x as u32);
                                geometry.raw(32, (x >> 32) as u32);
                            }
                        }
                        let models = self.models::<$t>(ty, n);
                        write_values::<$t>(geometry, models, &context, choice, $v);
                    }};
                }
                match values {
                    Values::U8(v) => typed!(v, u8),
                    Values::I32(v) => typed!(v, i32),
                    Values::U32(v) => typed!(v, u32),
                    Values::F32(v) => typed!(v, f32),
                    Values::F64(v) => typed!(v, f64),
                }
            }
            _ => unreachable!("only attribute ops are coded here"),
        }
    }

    /// Reads the op of `kind` the store will be asked to apply; counts are bounded by the
    /// store's slots (a set without ids covers every slot) and by `limit`, what the header
    /// leaves for the kind.
    pub(super) fn read(
        &mut self,
        kind: OpKind,
        store: &MeshStore,
        input: [&mut SymbolReader; 3],
        lists: &mut IdListCoder,
        limit: u64,
    ) -> Result<Op, CorruptStream> {
        let [ops, ids_in, geometry] = input;
        let (domain, name) = self.read_header(ops)?;
        if kind == OpKind::RemoveAttribute {
            return Ok(Op::RemoveAttribute { domain, name });
        }
        let ty = NumberType::ALL[ops.symbol(&mut self.number_type)?];
        let components = ops.symbol(&mut self.components)? as u8;
        if components == 0 {
            return Err(CorruptStream);
        }
        let ids = if ops.bit(&mut self.has_ids)? { Some(lists.read(ids_in, limit)?) } else { None };
        let elements = match &ids {
            Some(ids) => ids.len(),
            None => domain.len(store.vertex_slots() as usize, store.triangle_slots() as usize),
        };
        if elements as u64 > limit.max(1) {
            return Err(CorruptStream);
        }
        let predictor = Predictor::from_symbol(ops.symbol(&mut self.predictor)?);
        let choice = (predictor, (ops.symbol(&mut self.decorrelate)? as u8) << 1);
        let n = usize::from(components);
        let float = matches!(ty, NumberType::F32 | NumberType::F64);
        if let Predictor::Mesh(p) = predictor
            && (ids.is_some() || !p.fits(domain, n, float))
        {
            return Err(CorruptStream);
        }
        let slots = store.shared_slots();
        let whole = Whole::new(&slots, domain, matches!(predictor, Predictor::Mesh(_)));
        let mesh = whole.as_ref().map(|w| w.geometry(&slots));
        let mut context = Context::new(&slots, (domain, &name, n), ids.as_deref(), &mesh);
        if predictor == Predictor::Scaled {
            let mut f64_bits = || -> Result<f64, CorruptStream> {
                let low = u64::from(geometry.raw(32)?);
                Ok(f64::from_bits(low | u64::from(geometry.raw(32)?) << 32))
            };
            let (a, b) = (f64_bits()?, f64_bits()?);
            if !a.is_finite() || !b.is_finite() {
                return Err(CorruptStream);
            }
            context.scale = Some((a, b));
        }
        macro_rules! typed {
            ($t:ty, $wrap:path) => {{
                let models = self.models::<$t>(ty, n);
                $wrap(read_values::<$t>(geometry, models, &context, choice, elements)?)
            }};
        }
        let values = match ty {
            NumberType::U8 => typed!(u8, Values::U8),
            NumberType::I32 => typed!(i32, Values::I32),
            NumberType::U32 => typed!(u32, Values::U32),
            NumberType::F32 => typed!(f32, Values::F32),
            NumberType::F64 => typed!(f64, Values::F64),
        };
        Ok(Op::SetAttribute { domain, name, components, ids, values })
    }
}

/// For a set of every vertex slot: the slots in id order and the triangles around each,
/// for a packed mesh's predictors.
struct Whole {
    order: Vec<u32>,
    around: VertexTriangles,
}

impl Whole {
    /// `Some` for a set of every slot of the vertex domain when `wanted`.
    fn new(slots: &MeshData, domain: Domain, wanted: bool) -> Option<Self> {
        (wanted && domain == Domain::Vertex).then(|| Self {
            order: (0..slots.vertex_count() as u32).collect(),
            // Removed triangles' corners are past every vertex: left out.
            around: VertexTriangles::new(slots.vertex_count(), &slots.triangles),
        })
    }

    fn geometry<'a>(&'a self, slots: &'a MeshData) -> Geometry<'a> {
        Geometry::new(&slots.positions, &slots.triangles, &self.around, &self.order)
    }
}

/// What a `set-attribute`'s predictions read: the attribute as it is, the op's ids, and for
/// a set of every vertex the mesh in id order.
struct Context<'a> {
    domain: Domain,
    components: usize,
    ids: Option<&'a [u32]>,
    /// The attribute's values before the op, if the mesh has it in this shape.
    current: Option<&'a Values>,
    /// The value of an element the attribute does not cover yet.
    default: f64,
    geometry: &'a Option<Geometry<'a>>,
    /// `a` and `b` of [`Predictor::Scaled`].
    scale: Option<(f64, f64)>,
}

impl<'a> Context<'a> {
    /// For the op on `domain`'s `name` over `slots` (the store's, before the op).
    fn new(
        slots: &'a MeshData,
        (domain, name, components): (Domain, &str, usize),
        ids: Option<&'a [u32]>,
        geometry: &'a Option<Geometry<'a>>,
    ) -> Self {
        let shape = Attribute {
            domain,
            name: name.to_owned(),
            components: components as u8,
            values: Values::U8(Vec::new()),
        };
        let current = slots
            .attributes
            .get(domain, name)
            .filter(|a| usize::from(a.components) == components)
            .map(|a| &a.values);
        let default = shape.default_value();
        Self { domain, components, ids, current, default, geometry, scale: None }
    }

    /// The number `k` of the `j`th element before the op.
    fn current(&self, j: usize, k: usize) -> f64 {
        let (n, e) = (self.components, self.ids.map_or(j, |ids| ids[j] as usize));
        match self.current.filter(|v| n * e + k < v.len()) {
            Some(v) => v.get(n * e + k),
            None => self.default,
        }
    }

    /// The least-squares `a` and `b` of `new ≈ a current + b` over a sample of the op's
    /// numbers; `None` without values before the op or when nothing fits.
    fn fit<T: Number>(&self, values: &[T]) -> Option<(f64, f64)> {
        self.current?;
        let n = self.components;
        let elements = values.len() / n;
        let stride = elements.div_ceil(SAMPLE).max(1);
        let (mut count, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for j in (0..elements).step_by(stride) {
            for k in 0..n {
                let (x, y) = (self.current(j, k), values[n * j + k].value());
                (count, sx, sy, sxx, sxy) = (count + 1.0, sx + x, sy + y, sxx + x * x, sxy + x * y);
            }
        }
        let variance = count * sxx - sx * sx;
        let a = if variance > 0.0 { (count * sxy - sx * sy) / variance } else { 1.0 };
        let b = (sy - a * sx) / count;
        // Rounded to what a service would have written (a scale in f32): exact hits.
        let (a, b) = (f64::from(a as f32), f64::from(b as f32));
        (a.is_finite() && b.is_finite()).then_some((a, b))
    }

    /// What predicts with `predictor`; `None` where it cannot (a packed mesh's predictor
    /// without the whole mesh).
    fn predicting(&self, predictor: Predictor) -> Option<Predicting<'_, 'a>> {
        let mesh = match predictor {
            Predictor::Mesh(p) => {
                let geometry = self.geometry.as_ref()?;
                Some(Predictions::new(geometry, self.domain, p, self.components))
            }
            _ => None,
        };
        Some(Predicting { context: self, predictor, mesh })
    }
}

/// One predictor at work over one op's values.
struct Predicting<'c, 'a> {
    context: &'c Context<'a>,
    predictor: Predictor,
    mesh: Option<Predictions<'c, 'a>>,
}

impl Predicting<'_, '_> {
    /// The predicted images of the `j`th element's components, reading only the op's
    /// values before it.
    fn predict<T: Number>(&mut self, values: &[T], j: usize) -> [u64; MAX_COMPONENTS] {
        let c = self.context;
        let n = c.components;
        match self.predictor {
            Predictor::Zero => [0; MAX_COMPONENTS],
            Predictor::Previous if j == 0 => [0; MAX_COMPONENTS],
            Predictor::Previous => {
                std::array::from_fn(|k| if k < n { values[n * (j - 1) + k].image() } else { 0 })
            }
            Predictor::Current => {
                std::array::from_fn(|k| if k < n { T::nearest_image(c.current(j, k)) } else { 0 })
            }
            Predictor::Scaled => {
                let (a, b) = c.scale.unwrap_or((1.0, 0.0));
                std::array::from_fn(|k| {
                    if k < n { T::nearest_image(a * c.current(j, k) + b) } else { 0 }
                })
            }
            Predictor::Mesh(_) => self.mesh.as_mut().expect("made with the geometry").at(values, j),
        }
    }
}

fn write_values<T: Number>(
    w: &mut SymbolWriter,
    models: &mut ValueModels,
    context: &Context,
    (predictor, mask): (Predictor, u8),
    values: &[T],
) {
    let n = context.components;
    let mut predicting = context.predicting(predictor).expect("chosen among those that can");
    for j in 0..values.len() / n {
        let base = predicting.predict(values, j);
        let mut previous = 0;
        for k in 0..n {
            let actual = values[n * j + k].image();
            models.write::<T>(w, k, actual, adjusted::<T>(base[k], k, mask, previous));
            previous = difference::<T>(actual, base[k]);
        }
    }
}

fn read_values<T: Number>(
    r: &mut SymbolReader,
    models: &mut ValueModels,
    context: &Context,
    (predictor, mask): (Predictor, u8),
    elements: usize,
) -> Result<Vec<T>, CorruptStream> {
    let n = context.components;
    let mut predicting = context.predicting(predictor).ok_or(CorruptStream)?;
    let mut values = vec![T::default(); elements * n];
    for j in 0..elements {
        let base = predicting.predict(&values, j);
        let mut previous = 0;
        for k in 0..n {
            let predicted = adjusted::<T>(base[k], k, mask, previous);
            let actual = models.read::<T>(r, k, predicted)?;
            values[n * j + k] = T::from_image(actual);
            previous = difference::<T>(actual, base[k]);
        }
    }
    Ok(values)
}

/// The predictor and decorrelation mask with the smallest residuals, judged on a sample.
fn choose<T: Number>(context: &Context, float: bool, values: &[T]) -> (Predictor, u8) {
    let n = context.components;
    let elements = values.len() / n;
    let stride = elements.div_ceil(SAMPLE).max(1);
    let mut best = (f64::INFINITY, Predictor::Zero, 0u8);
    let mut candidates = vec![Predictor::Current, Predictor::Previous, Predictor::Zero];
    if context.scale.is_some() {
        candidates.push(Predictor::Scaled);
    }
    if context.geometry.is_some() {
        let mesh = MeshPredictor::candidates(context.domain, n, float);
        candidates
            .extend(mesh.into_iter().filter(|p| MESH_PREDICTORS.contains(p)).map(Predictor::Mesh));
    }
    for predictor in candidates {
        let Some(mut predicting) = context.predicting(predictor) else { continue };
        let mut costs = [[Costs::default(); 2]; MAX_COMPONENTS];
        for j in (0..elements).step_by(stride) {
            let base = predicting.predict(values, j);
            let mut previous = 0;
            for k in 0..n {
                let actual = values[n * j + k].image();
                costs[k][0].add(zigzag(difference::<T>(actual, base[k])), u8::MAX);
                if k > 0 {
                    let predicted = adjusted::<T>(base[k], k, 1 << k, previous);
                    costs[k][1].add(zigzag(difference::<T>(actual, predicted)), u8::MAX);
                }
                previous = difference::<T>(actual, base[k]);
            }
        }
        let (mut total, mut mask) = (0.0, 0u8);
        for (k, [plain, adjusted]) in costs.iter().enumerate().take(n) {
            if k > 0 && adjusted.plain() < plain.plain() {
                mask |= 1 << k;
                total += adjusted.plain();
            } else {
                total += plain.plain();
            }
        }
        if total < best.0 {
            best = (total, predictor, mask);
        }
    }
    (best.1, best.2)
}

fn type_index(ty: NumberType) -> usize {
    NumberType::ALL.iter().position(|&t| t == ty).expect("every type")
}
