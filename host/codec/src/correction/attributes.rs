//! Attribute ops in a correction. Values travel as their own bits (a colour is a byte, a
//! quality four), each number type in its own adaptive byte models, so repeated bytes
//! (an alpha of 255, the high bytes of similar floats) cost little.
//!
//! ops section: domain, number type, components, name (length, bytes), whether ids follow.
//! ids section: the ids. geometry section: the values' little-endian bytes.

use meshflow_mesh::attributes::{Domain, MAX_NAME_BYTES, NumberType, Values};
use meshflow_mesh::store::{MeshStore, Op, OpKind};

use super::coding::model::AdaptiveModel;
use super::coding::stream::{CorruptStream, SymbolReader, SymbolWriter};
use super::lists::IdListCoder;

const DOMAINS: [Domain; 3] = [Domain::Vertex, Domain::Face, Domain::Corner];
/// The widest number is eight bytes, each position with its own model.
const MAX_NUMBER_BYTES: usize = 8;

pub(super) struct AttributeCoder {
    domain: AdaptiveModel,
    number_type: AdaptiveModel,
    components: AdaptiveModel,
    name_byte: AdaptiveModel,
    has_ids: AdaptiveModel,
    /// Per number type, per byte of a number.
    bytes: Vec<[AdaptiveModel; MAX_NUMBER_BYTES]>,
}

impl AttributeCoder {
    pub(super) fn new() -> Self {
        Self {
            domain: AdaptiveModel::new(DOMAINS.len()),
            number_type: AdaptiveModel::new(NumberType::ALL.len()),
            components: AdaptiveModel::new(5),
            name_byte: AdaptiveModel::new(256),
            has_ids: AdaptiveModel::new(2),
            bytes: NumberType::ALL
                .iter()
                .map(|_| std::array::from_fn(|_| AdaptiveModel::new(256)))
                .collect(),
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

    /// Codes a `set-attribute` or `remove-attribute` (any other op is not this coder's).
    pub(super) fn write(
        &mut self,
        ops: &mut SymbolWriter,
        ids_out: &mut SymbolWriter,
        geometry: &mut SymbolWriter,
        lists: &mut IdListCoder,
        op: &Op,
    ) {
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
                let models = &mut self.bytes[type_index(ty)];
                for number in values.to_le_bytes().chunks_exact(ty.size()) {
                    for (model, &b) in models.iter_mut().zip(number) {
                        geometry.symbol(model, usize::from(b));
                    }
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
        ops: &mut SymbolReader,
        ids_in: &mut SymbolReader,
        geometry: &mut SymbolReader,
        lists: &mut IdListCoder,
        limit: u64,
    ) -> Result<Op, CorruptStream> {
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
        if elements as u64 > limit.max(1) && ids.is_some() {
            return Err(CorruptStream);
        }
        let numbers = elements * usize::from(components);
        let models = &mut self.bytes[type_index(ty)];
        let mut bytes = Vec::with_capacity(numbers * ty.size());
        for _ in 0..numbers {
            for model in &mut models[..ty.size()] {
                bytes.push(geometry.symbol(model)? as u8);
            }
        }
        let values = from_le_bytes(ty, &bytes);
        Ok(Op::SetAttribute { domain, name, components, ids, values })
    }
}

fn type_index(ty: NumberType) -> usize {
    NumberType::ALL.iter().position(|&t| t == ty).expect("every type")
}

fn from_le_bytes(ty: NumberType, bytes: &[u8]) -> Values {
    let n = ty.size();
    match ty {
        NumberType::U8 => Values::U8(bytes.to_vec()),
        NumberType::I32 => Values::I32(
            bytes.chunks_exact(n).map(|b| i32::from_le_bytes(b.try_into().expect("4"))).collect(),
        ),
        NumberType::U32 => Values::U32(
            bytes.chunks_exact(n).map(|b| u32::from_le_bytes(b.try_into().expect("4"))).collect(),
        ),
        NumberType::F32 => Values::F32(
            bytes.chunks_exact(n).map(|b| f32::from_le_bytes(b.try_into().expect("4"))).collect(),
        ),
        NumberType::F64 => Values::F64(
            bytes.chunks_exact(n).map(|b| f64::from_le_bytes(b.try_into().expect("8"))).collect(),
        ),
    }
}
