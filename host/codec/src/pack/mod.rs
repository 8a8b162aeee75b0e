//! The packed full-mesh format (`.mfm`): lossless, compact, fast both ways.
//!
//! ```text
//! magic "MFM\x1a" | version u16 LE | checksum [16] (BLAKE3 of every byte after it)
//! content hash [32] of the mesh, checked after decoding
//! varints: vertex count, triangle count, grid (0 none; 1 binary, then the zigzagged step
//!          exponent of each axis; 2 decimal, then the digits of each axis), connectivity
//!          bytes, geometry bytes, attribute bytes
//! connectivity section | geometry section (range coded) | attributes section (ending
//! exactly at the end; empty for a mesh without attributes)
//! ```
//!
//! Connectivity: triangles in order, each through the open edge it completes, its third
//! corner among the vertices that close the fan there ([`AdjacencyCoder`]); corners
//! without such an edge by recency, as the next unseen vertex, or explicitly. Geometry:
//! vertices in an order grown over the connectivity ([`CodingOrder`]: next the vertex with
//! the most known triangles), each an exact f32 residual from a parallelogram prediction over
//! already decoded neighbours, or on a mesh whose coordinates all lie on a coarse grid
//! ([`Grid::detect`], e.g. after `--quantize`), in grid steps from the snapped prediction.
//! Attributes (colours, normals, quality, texture coordinates, any number by name, and the
//! materials): every value exact, vertices' in the same coding order, each predicted from
//! what was decoded before it (`attributes.rs`, `values.rs`).
//! The format keeps vertex, triangle and corner order, so unpacking
//! gives back the same bytes, and the content hash is verified.
//!
//! ```
//! use meshflow_codec::pack;
//! use meshflow_mesh::MeshData;
//! let mesh = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5], vec![0, 1, 2]);
//! assert_eq!(pack::decode(&pack::encode(&mesh).unwrap()).unwrap(), mesh);
//! ```

mod adjacency;
mod attributes;
mod error;
mod open_edges;
mod order;
mod predict;
pub(crate) mod values;

pub use error::PackError;

use std::io::Read;

use crate::correction::coding::bytes::{
    ByteReader, SEALED_FRONT, open_sealed_versions, put_grid, put_varint, seal, sealed_front,
};
use crate::correction::coding::residual::ResidualCoder;
use crate::correction::coding::stream::{SymbolReader, SymbolWriter};
use crate::quantize::Grid;
use adjacency::AdjacencyCoder;
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_topology::VertexTriangles;
use order::CodingOrder;
use predict::predict;
use values::Geometry;

const MAGIC: [u8; 4] = *b"MFM\x1a";
/// The format version this build writes (6: the geometry in blocks a download decodes as
/// they arrive); it reads this one and 5 (attributes; the geometry in one stream).
pub const VERSION: u16 = 6;
const OLDEST_READ: u16 = 5;
/// Vertices per geometry block (format 6): about 400 KB of a scan, so a download at 5 Mbit/s
/// brings one every ~0.6 s, and what is left to decode after the last byte is one block.
const GEOMETRY_BLOCK: usize = 1 << 16;
/// Declared counts may exceed the bytes that carry them by at most this factor (the adaptive models'
/// probability floor keeps honest files above it), so a forged count cannot make the
/// decoder allocate more than a bounded multiple of its input.
const ELEMENTS_PER_BYTE: u64 = 1 << 13;
const ELEMENT_SLACK: u64 = 1 << 16;

/// Packs a mesh. Refuses meshes that are not whole triangles over existing vertices.
pub fn encode(mesh: &MeshData) -> Result<Vec<u8>, PackError> {
    validate(mesh)?;
    // The connectivity and the geometry are coded independently: on two threads.
    std::thread::scope(|scope| {
        let connectivity = scope.spawn(|| encode_connectivity(mesh));
        let (geometry, attributes, grid) = encode_geometry(mesh);
        let connectivity = connectivity.join().expect("coding the connectivity does not panic");
        Ok(seal_sections(mesh, grid, [&connectivity, &geometry, &attributes]))
    })
}

/// The geometry section (positions in coding order, in blocks), the attributes section, and
/// the grid the positions were found on.
fn encode_geometry(mesh: &MeshData) -> (Vec<u8>, Vec<u8>, Option<Grid>) {
    let vertex_count = mesh.vertex_count();
    let around = VertexTriangles::new(vertex_count, &mesh.triangles);
    let grid = Grid::detect([&mesh.positions[..]]);
    let (mut geometry, mut block) = (Vec::new(), SymbolWriter::new());
    let mut residuals = ResidualCoder::new(grid);
    let (positions, triangles) = (&mesh.positions, &mesh.triangles);
    let (mut order, mut previous) = (CodingOrder::new(&around, triangles), None);
    // Attributes follow the vertices in the order their positions were coded.
    let mut coded = Vec::with_capacity(if mesh.attributes.is_empty() { 0 } else { vertex_count });
    for done in 1.. {
        let Some(v) = order.next() else { break };
        let predicted = predict(v, previous, positions, order.decoded(), triangles, &around);
        let p = &positions[3 * v as usize..3 * v as usize + 3];
        residuals.write(&mut block, [p[0], p[1], p[2]], predicted);
        previous = Some(v);
        if !mesh.attributes.is_empty() {
            coded.push(v);
        }
        if done % GEOMETRY_BLOCK == 0 || done == vertex_count {
            let bytes = std::mem::replace(&mut block, SymbolWriter::new()).finish();
            put_varint(&mut geometry, bytes.len() as u64);
            geometry.extend_from_slice(&bytes);
        }
    }
    let attributes = match mesh.attributes.is_empty() {
        true => Vec::new(),
        false => attributes::write(
            &mesh.attributes,
            &Geometry::new(positions, triangles, &around, &coded),
        ),
    };
    (geometry, attributes, grid)
}

/// The file: front, header and the three sections, sealed.
fn seal_sections(mesh: &MeshData, grid: Option<Grid>, sections: [&[u8]; 3]) -> Vec<u8> {
    let [connectivity, geometry, attributes] = sections;
    let length = connectivity.len() + geometry.len() + attributes.len();
    let mut out = sealed_front(MAGIC, VERSION, 64 + length);
    out.extend_from_slice(&mesh.content_hash().0);
    put_varint(&mut out, mesh.vertex_count() as u64);
    put_varint(&mut out, mesh.triangle_count() as u64);
    put_grid(&mut out, grid);
    put_varint(&mut out, connectivity.len() as u64);
    put_varint(&mut out, geometry.len() as u64);
    put_varint(&mut out, attributes.len() as u64);
    out.extend_from_slice(connectivity);
    out.extend_from_slice(geometry);
    out.extend_from_slice(attributes);
    seal(&mut out);
    out
}

/// The content hash a packed mesh states, its seal checked and nothing decoded: the hash
/// [`decode`] holds the mesh to, so whoever decodes these bytes gets that mesh or an error.
pub fn stated_hash(bytes: &[u8]) -> Result<ContentHash, PackError> {
    Ok(ContentHash(open_sealed_versions(bytes, MAGIC, OLDEST_READ..=VERSION)?.0.array()?))
}

/// Unpacks a mesh; any damage is a typed error.
pub fn decode(bytes: &[u8]) -> Result<MeshData, PackError> {
    Ok(decode_arriving(&mut Whole(bytes))?.0)
}

/// Unpacks a mesh whose bytes `source` yields as they arrive (a download): the connectivity
/// is decoded, and the table the geometry's predictions walk is built, while the geometry
/// section is still coming, so what is left when the last byte is in is the geometry alone.
/// The same checks as [`decode`], in the same order (the checksum of the whole before any
/// decoded part is believed); `source` ending early is [`PackError::Truncated`]. With the
/// mesh comes its content hash, as stated and found.
pub fn decode_from(source: impl Read) -> Result<(MeshData, ContentHash), PackError> {
    decode_arriving(&mut Arriving { source, bytes: Vec::new(), ended: false })
}

fn decode_arriving(source: &mut impl Arrival) -> Result<(MeshData, ContentHash), PackError> {
    // Decoded before the checksum is known, so their errors wait for the checksum's verdict.
    let early = early(source);
    let bytes = source.all()?;
    let (mut r, version) = open_sealed_versions(bytes, MAGIC, OLDEST_READ..=VERSION)?;
    let header = Header::read(&mut r)?;
    if !header.fits_in(bytes.len()) {
        return Err(PackError::Malformed(format!(
            "{} vertices and {} triangles in {} bytes",
            header.vertices,
            header.triangles,
            bytes.len()
        )));
    }
    let connectivity = r.take(header.connectivity)?;
    let geometry = r.take(header.geometry)?;
    let attributes = r.take(header.attributes)?;
    if r.remaining() != 0 {
        return Err(PackError::Malformed(format!("{} bytes after the attributes", r.remaining())));
    }
    let (connectivity, decoded) = match early {
        Some(Early { connectivity, geometry: decoded }) => (connectivity?, decoded),
        None => (Connectivity::decode(&header, connectivity)?, None),
    };
    let Positions { positions, coded } = match decoded {
        Some(decoded) => decoded?,
        None => {
            let section = 0..geometry.len();
            Positions::decode(&mut Whole(geometry), section, &header, version, &connectivity)?
        }
    };
    let Connectivity { triangles, around } = connectivity;
    if let Some(i) = positions.iter().position(|c| !c.is_finite()) {
        return Err(PackError::Malformed(format!("vertex {} has a non-finite coordinate", i / 3)));
    }
    let attributes =
        attributes::read(attributes, &Geometry::new(&positions, &triangles, &around, &coded))?;
    let mut mesh = MeshData::new(positions, triangles);
    mesh.attributes = attributes;
    let found = mesh.content_hash();
    if found != header.hash {
        return Err(PackError::HashMismatch { expected: header.hash, found });
    }
    Ok((mesh, found))
}

/// What was decoded while the bytes arrived.
struct Early {
    connectivity: Result<Connectivity, PackError>,
    /// After a good connectivity: the geometry, block by block as each came in.
    geometry: Option<Result<Positions, PackError>>,
}

/// The connectivity, decoded as soon as its section is in, then the geometry, each block as
/// soon as it is in: `None` when the front is unreadable or its counts need more bytes to
/// be believed than those in hand (a point cloud's vertices are paid for by its geometry;
/// [`decode_arriving`] then decodes everything once it is in and judged).
fn early(source: &mut impl Arrival) -> Option<Early> {
    let front = source.at_least(FRONT_MAX).ok()?;
    let version = u16::from_le_bytes([*front.get(4)?, *front.get(5)?]);
    let mut r = ByteReader::new(front.get(SEALED_FRONT..)?);
    let header = Header::read(&mut r).ok()?;
    let start = front.len() - r.remaining();
    let end = start.checked_add(header.connectivity)?;
    if !(OLDEST_READ..=VERSION).contains(&version) || !header.fits_in(end) {
        return None;
    }
    let arrived = source.at_least(end).ok()?;
    let connectivity = Connectivity::decode(&header, arrived.get(start..end)?);
    let geometry = match (&connectivity, end.checked_add(header.geometry)) {
        (Ok(connectivity), Some(geometry_end)) => {
            Some(Positions::decode(source, end..geometry_end, &header, version, connectivity))
        }
        _ => None,
    };
    Some(Early { connectivity, geometry })
}

/// What follows the sealed front: the content hash, counts, grid and section lengths.
struct Header {
    hash: ContentHash,
    vertices: u64,
    triangles: u64,
    grid: Option<Grid>,
    connectivity: usize,
    geometry: usize,
    attributes: usize,
}

impl Header {
    fn read(r: &mut ByteReader<'_>) -> Result<Self, PackError> {
        let hash = ContentHash(r.array()?);
        let (vertices, triangles) = (r.varint()?, r.varint()?);
        let grid = r.grid()?;
        let mut section = || usize::try_from(r.varint()?).map_err(|_| PackError::Truncated);
        let (connectivity, geometry, attributes) = (section()?, section()?, section()?);
        Ok(Self { hash, vertices, triangles, grid, connectivity, geometry, attributes })
    }

    /// Whether `bytes` bytes can hold the counts (see [`ELEMENTS_PER_BYTE`]).
    fn fits_in(&self, bytes: usize) -> bool {
        let budget = ELEMENTS_PER_BYTE * bytes as u64 + ELEMENT_SLACK;
        self.vertices <= u64::from(u32::MAX)
            && self.triangles <= budget
            && self.vertices + self.triangles <= budget
    }
}

/// The triangles and, for the geometry's predictions, the triangles around each vertex.
struct Connectivity {
    triangles: Vec<u32>,
    around: VertexTriangles,
}

impl Connectivity {
    fn decode(header: &Header, section: &[u8]) -> Result<Self, PackError> {
        let bad_connectivity = |_| PackError::Corrupt("connectivity");
        let mut input = SymbolReader::new(section).map_err(bad_connectivity)?;
        let mut coder = AdjacencyCoder::new(header.vertices as u32);
        let mut triangles = Vec::new();
        for _ in 0..header.triangles {
            triangles.extend(coder.read(&mut input).map_err(bad_connectivity)?);
        }
        let around = VertexTriangles::new(header.vertices as usize, &triangles);
        Ok(Self { triangles, around })
    }
}

/// The vertices' positions, and their coding order when attributes follow it.
struct Positions {
    positions: Vec<f32>,
    coded: Vec<u32>,
}

impl Positions {
    /// Decodes the geometry section, `section` of `source`'s bytes: one stream (format 5) or
    /// blocks of [`GEOMETRY_BLOCK`] vertices, each decoded as soon as it has arrived.
    fn decode(
        source: &mut impl Arrival,
        section: std::ops::Range<usize>,
        header: &Header,
        version: u16,
        connectivity: &Connectivity,
    ) -> Result<Self, PackError> {
        let vertex_count = header.vertices as usize;
        let mut walk = Walk {
            connectivity,
            order: CodingOrder::new(&connectivity.around, &connectivity.triangles),
            previous: None,
            residuals: ResidualCoder::new(header.grid),
            positions: vec![0.0; 3 * vertex_count],
            coded: Vec::new(),
            keep_order: header.attributes > 0,
        };
        if version == OLDEST_READ {
            let arrived = source.at_least(section.end)?;
            walk.stream(arrived.get(section).ok_or(PackError::Truncated)?, vertex_count)?;
        } else {
            let (mut at, mut left) = (section.start, vertex_count);
            while left > 0 {
                let stream = block(source, at, section.end)?;
                let count = left.min(GEOMETRY_BLOCK);
                let arrived = source.at_least(stream.end)?;
                walk.stream(arrived.get(stream.clone()).ok_or(PackError::Truncated)?, count)?;
                (at, left) = (stream.end, left - count);
            }
            if at != section.end {
                let extra = section.end - at;
                return Err(PackError::Malformed(format!("{extra} bytes after the geometry")));
            }
        }
        Ok(Self { positions: walk.positions, coded: walk.coded })
    }
}

/// The geometry decoder's state between streams: the coding order and the adaptive models
/// go on from one block to the next.
struct Walk<'a> {
    connectivity: &'a Connectivity,
    order: CodingOrder<'a>,
    previous: Option<u32>,
    residuals: ResidualCoder,
    positions: Vec<f32>,
    coded: Vec<u32>,
    keep_order: bool,
}

impl Walk<'_> {
    /// The next `count` vertices in coding order, from one coded stream.
    fn stream(&mut self, bytes: &[u8], count: usize) -> Result<(), PackError> {
        let bad_geometry = |_| PackError::Corrupt("geometry");
        let Connectivity { triangles, around } = self.connectivity;
        let mut input = SymbolReader::new(bytes).map_err(bad_geometry)?;
        for _ in 0..count {
            let v = self.order.next().ok_or(PackError::Corrupt("geometry"))?;
            let (positions, decoded) = (&self.positions, self.order.decoded());
            let predicted = predict(v, self.previous, positions, decoded, triangles, around);
            let p = self.residuals.read(&mut input, predicted).map_err(bad_geometry)?;
            self.positions[3 * v as usize..3 * v as usize + 3].copy_from_slice(&p);
            self.previous = Some(v);
            if self.keep_order {
                self.coded.push(v);
            }
        }
        Ok(())
    }
}

/// The range of the geometry block whose length prefix starts at `at` (within `end`).
fn block(
    source: &mut impl Arrival,
    at: usize,
    end: usize,
) -> Result<std::ops::Range<usize>, PackError> {
    let arrived = source.at_least(at.saturating_add(10).min(end))?;
    let prefix = arrived.get(at..end.min(arrived.len())).ok_or(PackError::Truncated)?;
    let mut r = ByteReader::new(prefix);
    let len = usize::try_from(r.varint()?).map_err(|_| PackError::Truncated)?;
    let start = at + (prefix.len() - r.remaining());
    match start.checked_add(len) {
        Some(stream_end) if stream_end <= end => Ok(start..stream_end),
        _ => Err(PackError::Malformed("a geometry block longer than its section".into())),
    }
}

/// The sealed front and the longest header: a hash, five varints and a grid.
const FRONT_MAX: usize = SEALED_FRONT + 32 + 5 * 10 + 31;

/// A packed mesh's bytes, whole or still arriving.
trait Arrival {
    /// The bytes so far, at least `n` of them unless the stream ended first.
    fn at_least(&mut self, n: usize) -> Result<&[u8], PackError>;
    /// Every byte, the stream having ended.
    fn all(&mut self) -> Result<&[u8], PackError>;
}

struct Whole<'a>(&'a [u8]);

impl Arrival for Whole<'_> {
    fn at_least(&mut self, _: usize) -> Result<&[u8], PackError> {
        Ok(self.0)
    }

    fn all(&mut self) -> Result<&[u8], PackError> {
        Ok(self.0)
    }
}

/// Bytes read from a stream into one buffer, only as far as asked.
struct Arriving<R> {
    source: R,
    bytes: Vec<u8>,
    ended: bool,
}

impl<R: Read> Arrival for Arriving<R> {
    fn at_least(&mut self, n: usize) -> Result<&[u8], PackError> {
        if self.bytes.len() < n && !self.ended {
            let wanted = (n - self.bytes.len()) as u64;
            let read = (&mut self.source).take(wanted).read_to_end(&mut self.bytes)?;
            self.ended = (read as u64) < wanted;
        }
        Ok(&self.bytes)
    }

    fn all(&mut self) -> Result<&[u8], PackError> {
        if !self.ended {
            self.source.read_to_end(&mut self.bytes)?;
            self.ended = true;
        }
        Ok(&self.bytes)
    }
}

/// Codes the triangles through the edges they share.
fn encode_connectivity(mesh: &MeshData) -> Vec<u8> {
    let mut out = SymbolWriter::new();
    let mut coder = AdjacencyCoder::new(mesh.vertex_count() as u32);
    for t in mesh.triangles.chunks_exact(3) {
        coder.write(&mut out, [t[0], t[1], t[2]]);
    }
    out.finish()
}

fn validate(mesh: &MeshData) -> Result<(), PackError> {
    let invalid = |m: String| Err(PackError::InvalidMesh(m));
    if !mesh.positions.len().is_multiple_of(3) || !mesh.triangles.len().is_multiple_of(3) {
        return invalid("positions or triangles are not whole triples".into());
    }
    let vertices = mesh.vertex_count();
    if u32::try_from(vertices).is_err() {
        return invalid(format!("{vertices} vertices do not fit u32 ids"));
    }
    if let Some(i) = mesh.positions.iter().position(|c| !c.is_finite()) {
        return invalid(format!("vertex {} has a non-finite coordinate", i / 3));
    }
    if let Some(v) = mesh.triangles.iter().find(|&&v| v as usize >= vertices) {
        return invalid(format!("corner {v} is not one of the {vertices} vertices"));
    }
    match mesh.attributes.check(vertices, mesh.triangle_count()) {
        Err(e) => invalid(e.to_string()),
        Ok(()) => Ok(()),
    }
}
