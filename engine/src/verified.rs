//! Meshes served to users, checked before a byte leaves (DESIGN §10), in bounded memory
//! whatever their size: the holding host's `raw` answer is streamed to a spool file under
//! the engine's data folder, capped, and hashed as it comes (a `raw` mesh's content hash is
//! the BLAKE3 of its bytes, see [`meshflow_api::raw_mesh`]); only a mesh whose hash is the
//! record's goes on. PLY, OBJ, OFF and STL are then written here from those verified arrays
//! (writing arrays out needs no mesh library, which the engine must not link), so no host's
//! converter is believed: one that would serve another mesh in some format is never asked
//! to. `.mfm` is packed by the host (the engine cannot pack): it is served only after the
//! same host's `raw` proved it holds the right mesh, and its sealed header makes every
//! reader's decode check the hash again.

use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::os::unix::fs::FileExt;
use std::path::Path;

use futures_util::StreamExt;
use meshflow_api::ClientError;
use meshflow_api::host::MeshFileFormat;
use meshflow_api::raw_mesh::{self, HASH_TAG, HEADER_BYTES, MAGIC};
use tokio::io::AsyncWriteExt;

/// What a spool holds in memory on its way to disk, and what a writer buffers.
const BUFFER_BYTES: usize = 256 << 10;

/// Why a host's answer could not be spooled or checked.
#[derive(Debug, thiserror::Error)]
pub enum SpoolError {
    #[error(transparent)]
    Fetch(#[from] ClientError),
    #[error("the answer is larger than the limit of {0} bytes")]
    TooLarge(u64),
    #[error(transparent)]
    NotRaw(#[from] raw_mesh::RawMeshError),
    #[error("spooling the answer: {0}")]
    Io(#[from] std::io::Error),
}

/// A host's answer on disk (deleted when dropped), its size and, for a `raw` one, the
/// content hash of the mesh it holds.
pub struct Spooled {
    pub path: tempfile::TempPath,
    pub bytes: u64,
    pub hash: Option<String>,
}

/// Streams `response`'s body to a new file under `dir`, at most `limit` bytes; `raw`: it
/// must be a `raw` mesh, and its content hash is taken on the way.
pub async fn spool(
    response: reqwest::Response,
    url: &str,
    dir: &Path,
    limit: u64,
    raw: bool,
) -> Result<Spooled, SpoolError> {
    if response.content_length().is_some_and(|n| n > limit) {
        return Err(SpoolError::TooLarge(limit));
    }
    std::fs::create_dir_all(dir)?;
    let path = tempfile::Builder::new().prefix(".download-").tempfile_in(dir)?.into_temp_path();
    let file = tokio::fs::File::create(&path).await?;
    let mut file = tokio::io::BufWriter::with_capacity(BUFFER_BYTES, file);
    let mut hasher = blake3::Hasher::new();
    hasher.update(HASH_TAG);
    let mut header = Vec::with_capacity(HEADER_BYTES);
    let mut bytes = 0u64;
    let mut body = response.bytes_stream();
    while let Some(chunk) = body.next().await {
        let chunk = chunk.map_err(|e| ClientError::Protocol {
            url: url.to_owned(),
            message: format!("the answer broke off: {e}"),
        })?;
        if bytes + chunk.len() as u64 > limit {
            return Err(SpoolError::TooLarge(limit));
        }
        if raw {
            // Everything after the magic is hashed; the header is kept to check the length.
            let skip = MAGIC.len().saturating_sub(bytes as usize).min(chunk.len());
            hasher.update(&chunk[skip..]);
            let wanted = HEADER_BYTES.saturating_sub(header.len()).min(chunk.len());
            header.extend_from_slice(&chunk[..wanted]);
        }
        bytes += chunk.len() as u64;
        file.write_all(&chunk).await?;
    }
    file.flush().await?;
    let hash = match raw {
        false => None,
        true => {
            let (vertices, triangles) = raw_mesh::header_counts(&header)?;
            let expected = raw_mesh::arrays_end(vertices, triangles);
            if bytes < expected {
                let error =
                    raw_mesh::RawMeshError::Length { vertices, triangles, expected, actual: bytes };
                return Err(error.into());
            }
            if bytes > expected {
                section(&path, vertices, triangles, bytes).await?;
            }
            Some(hasher.finalize().to_hex().to_string())
        }
    };
    Ok(Spooled { path, bytes, hash })
}

/// The attribute section of the spooled raw mesh at `path`, checked against its counts.
async fn section(
    path: &Path,
    vertices: u32,
    triangles: u32,
    bytes: u64,
) -> Result<raw_mesh::Section, SpoolError> {
    let path = path.to_owned();
    tokio::task::spawn_blocking(move || read_attributes(&path, vertices, triangles, bytes))
        .await
        .map_err(std::io::Error::other)?
}

fn read_attributes(
    path: &Path,
    vertices: u32,
    triangles: u32,
    bytes: u64,
) -> Result<raw_mesh::Section, SpoolError> {
    let start = raw_mesh::arrays_end(vertices, triangles);
    let mut file = std::fs::File::open(path)?;
    file.seek(SeekFrom::Start(start))?;
    let mut input = BufReader::with_capacity(BUFFER_BYTES, file);
    Ok(raw_mesh::read_section(&mut input, start, bytes, vertices, triangles)?)
}

/// A file written here from a verified `raw` mesh.
pub struct Written {
    pub path: tempfile::TempPath,
    pub bytes: u64,
    /// What the mesh carries that the file does not (`vertex color (4 x u8)`): PLY keeps
    /// every attribute and the texture names; OBJ, OFF and STL as the engine writes them keep
    /// positions and triangles only.
    pub not_kept: Vec<String>,
}

/// Writes the verified `raw` mesh at `raw` as `format` (PLY, OBJ, OFF or STL) into a new
/// file under `dir`, on a blocking thread, in bounded memory.
pub async fn write_format(
    raw: &Path,
    format: MeshFileFormat,
    dir: &Path,
) -> std::io::Result<Written> {
    let out = tempfile::Builder::new().prefix(".download-").tempfile_in(dir)?.into_temp_path();
    let (raw, target) = (raw.to_owned(), out.to_path_buf());
    let (bytes, not_kept) =
        tokio::task::spawn_blocking(move || write_blocking(&raw, format, &target))
            .await
            .map_err(std::io::Error::other)??;
    Ok(Written { path: out, bytes, not_kept })
}

/// What `format`, as written here, leaves out of a mesh with `section`.
fn not_kept(section: &raw_mesh::Section, format: MeshFileFormat) -> Vec<String> {
    let mut left: Vec<String> = match format {
        MeshFileFormat::Ply => Vec::new(),
        _ => section
            .attributes
            .iter()
            .map(|a| {
                let domain = match a.domain {
                    raw_mesh::Domain::Vertex => "vertex",
                    raw_mesh::Domain::Face => "face",
                    raw_mesh::Domain::Corner => "corner",
                };
                format!("{domain} {} ({} x {})", a.name, a.components, a.number_type)
            })
            .collect(),
    };
    if !section.materials.is_empty() {
        left.push(format!("materials {}", section.materials.join(", ")));
    }
    if !section.libraries.is_empty() {
        left.push(format!("material libraries {}", section.libraries.join(", ")));
    }
    if format != MeshFileFormat::Ply && !section.textures.is_empty() {
        left.push(format!("textures {}", section.textures.join(", ")));
    }
    left
}

fn write_blocking(
    raw: &Path,
    format: MeshFileFormat,
    target: &Path,
) -> std::io::Result<(u64, Vec<String>)> {
    let file = std::fs::File::open(raw)?;
    let mut input = BufReader::with_capacity(BUFFER_BYTES, &file);
    let mut header = [0u8; HEADER_BYTES];
    input.read_exact(&mut header)?;
    let (vertices, triangles) = raw_mesh::header_counts(&header).map_err(std::io::Error::other)?;
    let length = file.metadata()?.len();
    let section = match length > raw_mesh::arrays_end(vertices, triangles) {
        true => read_attributes(raw, vertices, triangles, length).map_err(std::io::Error::other)?,
        false => raw_mesh::Section::default(),
    };
    let mut out = BufWriter::with_capacity(BUFFER_BYTES, std::fs::File::create(target)?);
    let real = |bits: u32| f32::from_bits(bits);
    match format {
        MeshFileFormat::Ply => {
            let per_vertex = ply_properties(&section, raw_mesh::Domain::Vertex);
            let per_face = ply_properties(&section, raw_mesh::Domain::Face);
            let corner_uv = section.attributes.iter().find(|a| {
                a.domain == raw_mesh::Domain::Corner && a.name == "texcoord" && a.components == 2
            });
            writeln!(out, "ply\nformat binary_little_endian 1.0")?;
            for texture in &section.textures {
                writeln!(out, "comment TextureFile {texture}")?;
            }
            writeln!(out, "element vertex {vertices}")?;
            writeln!(out, "property float x\nproperty float y\nproperty float z")?;
            for (_, names, ty) in &per_vertex {
                names.iter().try_for_each(|n| writeln!(out, "property {ty} {n}"))?;
            }
            writeln!(out, "element face {triangles}")?;
            writeln!(out, "property list uchar int vertex_indices")?;
            if corner_uv.is_some() {
                writeln!(out, "property list uchar float texcoord")?;
            }
            for (_, names, ty) in &per_face {
                names.iter().try_for_each(|n| writeln!(out, "property {ty} {n}"))?;
            }
            writeln!(out, "end_header")?;
            let mut vertex_values = values_readers(raw, &per_vertex)?;
            for _ in 0..vertices {
                // The positions are already f32 LE, as binary PLY wants them.
                std::io::copy(&mut (&mut input).take(12), &mut out)?;
                copy_element(&mut vertex_values, &mut out)?;
            }
            let mut face_values = values_readers(raw, &per_face)?;
            let mut uv = match corner_uv {
                Some(a) => Some(reader_at(raw, a.offset)?),
                None => None,
            };
            for _ in 0..triangles {
                let corners = three(&mut input)?;
                out.write_all(&[3])?;
                for corner in corners {
                    out.write_all(&corner.to_le_bytes())?;
                }
                if let Some(uv) = &mut uv {
                    out.write_all(&[6])?;
                    std::io::copy(&mut uv.take(24), &mut out)?;
                }
                copy_element(&mut face_values, &mut out)?;
            }
        }
        MeshFileFormat::Obj | MeshFileFormat::Off => {
            let obj = format == MeshFileFormat::Obj;
            if !obj {
                writeln!(out, "OFF\n{vertices} {triangles} 0")?;
            }
            for _ in 0..vertices {
                let [x, y, z] = three(&mut input)?.map(real);
                match obj {
                    true => writeln!(out, "v {x} {y} {z}")?,
                    false => writeln!(out, "{x} {y} {z}")?,
                }
            }
            for _ in 0..triangles {
                let [a, b, c] = three(&mut input)?;
                match obj {
                    true => writeln!(out, "f {} {} {}", a + 1, b + 1, c + 1)?,
                    false => writeln!(out, "3 {a} {b} {c}")?,
                }
            }
        }
        MeshFileFormat::Stl => {
            out.write_all(&[0u8; 80])?;
            out.write_all(&triangles.to_le_bytes())?;
            // The triangles in order; each corner's position read where it lies.
            let mut triangles_at = input;
            std::io::copy(
                &mut (&mut triangles_at).take(12 * u64::from(vertices)),
                &mut std::io::sink(),
            )?;
            let position = |index: u32| -> std::io::Result<[f32; 3]> {
                if index >= vertices {
                    return Err(std::io::Error::other(format!("corner {index} out of range")));
                }
                let mut words = [0u8; 12];
                file.read_exact_at(&mut words, HEADER_BYTES as u64 + 12 * u64::from(index))?;
                let word =
                    |i: usize| u32::from_le_bytes(words[4 * i..4 * i + 4].try_into().unwrap());
                Ok([real(word(0)), real(word(1)), real(word(2))])
            };
            for _ in 0..triangles {
                let corners = three(&mut triangles_at)?;
                let [a, b, c] =
                    [position(corners[0])?, position(corners[1])?, position(corners[2])?];
                let (u, v) = (sub(b, a), sub(c, a));
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                let n = if length > 0.0 { n.map(|x| x / length) } else { [0.0; 3] };
                for point in [n, a, b, c] {
                    for x in point {
                        out.write_all(&x.to_le_bytes())?;
                    }
                }
                out.write_all(&[0, 0])?;
            }
        }
        MeshFileFormat::Mfm | MeshFileFormat::Raw => {
            return Err(std::io::Error::other("mfm and raw are not written here"));
        }
    }
    out.flush()?;
    Ok((out.get_ref().metadata()?.len(), not_kept(&section, format)))
}

/// A domain's attributes as PLY properties: the attribute, its property names (MeshLab's
/// for the well-known ones), and their PLY type.
fn ply_properties(
    section: &raw_mesh::Section,
    domain: raw_mesh::Domain,
) -> Vec<(&raw_mesh::RawAttribute, Vec<String>, &'static str)> {
    let vertex = domain == raw_mesh::Domain::Vertex;
    section
        .attributes
        .iter()
        .filter(|a| a.domain == domain)
        .map(|a| {
            let names: Vec<String> = match (vertex, a.name.as_str()) {
                (true, "color") => ["red", "green", "blue", "alpha"].map(String::from).to_vec(),
                (true, "normal") => ["nx", "ny", "nz"].map(String::from).to_vec(),
                (true, "texcoord") => ["texture_u", "texture_v"].map(String::from).to_vec(),
                (false, "material") => vec!["texnumber".to_owned()],
                (_, name) if a.components == 1 => vec![name.to_owned()],
                (_, name) => (0..a.components).map(|k| format!("{name}_{k}")).collect(),
            };
            let ty = match a.number_type {
                "u8" => "uchar",
                "i32" => "int",
                "u32" => "uint",
                "f64" => "double",
                _ => "float",
            };
            (a, names, ty)
        })
        .collect()
}

/// One reader per attribute, at its first number, with the bytes an element takes.
fn values_readers(
    raw: &Path,
    properties: &[(&raw_mesh::RawAttribute, Vec<String>, &'static str)],
) -> std::io::Result<Vec<(BufReader<std::fs::File>, u64)>> {
    properties
        .iter()
        .map(|(a, ..)| Ok((reader_at(raw, a.offset)?, u64::from(a.components) * a.number_bytes())))
        .collect()
}

fn reader_at(raw: &Path, offset: u64) -> std::io::Result<BufReader<std::fs::File>> {
    let mut file = std::fs::File::open(raw)?;
    file.seek(SeekFrom::Start(offset))?;
    Ok(BufReader::with_capacity(BUFFER_BYTES / 4, file))
}

/// Copies one element's numbers of every attribute, in property order (already LE).
fn copy_element(
    readers: &mut [(BufReader<std::fs::File>, u64)],
    out: &mut impl Write,
) -> std::io::Result<()> {
    for (reader, bytes) in readers {
        std::io::copy(&mut reader.take(*bytes), out)?;
    }
    Ok(())
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Three u32 LE words: a position's bits or a triangle's corners.
fn three(input: &mut impl Read) -> std::io::Result<[u32; 3]> {
    let mut words = [0u8; 12];
    input.read_exact(&mut words)?;
    let word = |i: usize| u32::from_le_bytes(words[4 * i..4 * i + 4].try_into().expect("four"));
    Ok([word(0), word(1), word(2)])
}

#[cfg(test)]
mod tests {

    use axum::body::{Body, Bytes};
    use meshflow_api::HostClient;
    use meshflow_api::host::ConvertMesh;

    use crate::downloads::{DownloadError, Downloads, Hosts, Which};
    use crate::record::{RunRecord, Status};

    use super::*;

    /// A `raw` mesh of one triangle whose first corner is at `x`, and its content hash.
    fn triangle(x: f32) -> (Vec<u8>, String) {
        let mut raw = MAGIC.to_vec();
        raw.extend([3u32, 1].iter().flat_map(|v| v.to_le_bytes()));
        raw.extend([x, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()));
        raw.extend([0u32, 1, 2].iter().flat_map(|v| v.to_le_bytes()));
        let hash = raw_mesh::content_hash(&raw).unwrap();
        (raw, hash)
    }

    /// A triangle with a colour and a quality per vertex, as a host's `raw` answer has them.
    fn coloured_triangle() -> Vec<u8> {
        let (mut raw, _) = triangle(0.0);
        raw.extend(raw_mesh::ATTRIBUTES_TAG);
        raw.extend(2u32.to_le_bytes());
        raw.extend([0, 0, 4]);
        raw.extend(5u32.to_le_bytes());
        raw.extend(b"color");
        raw.extend(12u64.to_le_bytes());
        raw.extend([255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128]);
        raw.extend([0, 3, 1]);
        raw.extend(7u32.to_le_bytes());
        raw.extend(b"quality");
        raw.extend(3u64.to_le_bytes());
        raw.extend([0.5f32, 1.5, -2.0].iter().flat_map(|v| v.to_le_bytes()));
        for _ in 0..3 {
            raw.extend(0u32.to_le_bytes());
        }
        raw
    }

    #[tokio::test]
    async fn ply_keeps_a_meshs_attributes_and_other_formats_say_what_they_leave_out() {
        let dir = tempfile::tempdir().unwrap();
        let raw = dir.path().join("mesh.raw");
        std::fs::write(&raw, coloured_triangle()).unwrap();
        let ply = write_format(&raw, MeshFileFormat::Ply, dir.path()).await.unwrap();
        assert!(ply.not_kept.is_empty(), "{:?}", ply.not_kept);
        let bytes = std::fs::read(&ply.path).unwrap();
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = String::from_utf8_lossy(&bytes[..end]);
        for line in ["property uchar red", "property uchar alpha", "property float quality"] {
            assert!(header.contains(line), "{header}");
        }
        // Each vertex: x y z, then red green blue alpha, then quality.
        let second = &bytes[end + 20..end + 40];
        assert_eq!(second[..4], 1f32.to_le_bytes());
        assert_eq!(second[12..16], [0, 255, 0, 255]);
        assert_eq!(second[16..], 1.5f32.to_le_bytes());

        let obj = write_format(&raw, MeshFileFormat::Obj, dir.path()).await.unwrap();
        assert_eq!(obj.not_kept, ["vertex color (4 x u8)", "vertex quality (1 x f32)"]);
    }

    struct One(String);

    impl Hosts for One {
        fn registered(&self, url: &str) -> Option<HostClient> {
            url.starts_with(&self.0).then(|| HostClient::new(&self.0))
        }

        fn up(&self) -> Vec<HostClient> {
            vec![HostClient::new(&self.0)]
        }
    }

    fn completed(host: &str, hash: &str) -> RunRecord {
        let mut record = RunRecord::new("r-1".into(), crate::workflow::Transfer::Auto);
        record.status = Status::Completed;
        record.result = Some(meshflow_api::engine::ResultRecord {
            url: format!("{host}/blobs/{hash}.mfm"),
            hash: hash.to_owned(),
            bytes: None,
            vertices: 3,
            triangles: 1,
            copies: Vec::new(),
        });
        record
    }

    /// A host that answers every conversion with `answer(format)`.
    async fn host(
        answer: impl Fn(MeshFileFormat) -> Body + Clone + Send + Sync + 'static,
    ) -> String {
        let app = axum::Router::new().route(
            "/meshes/convert",
            axum::routing::post(move |axum::Json(request): axum::Json<ConvertMesh>| {
                let answer = answer.clone();
                async move { answer(request.format) }
            }),
        );
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });
        url
    }

    #[tokio::test]
    async fn a_lying_converter_is_refused_and_an_honest_one_is_written_here() {
        let (honest, hash) = triangle(0.0);
        let (other, _) = triangle(5.0);
        let dir = tempfile::tempdir().unwrap();
        let downloads = Downloads::spooling_in(dir.path().to_owned());
        // Another mesh, in every format: the arrays give it away.
        let liar = host(move |_| Body::from(other.clone())).await;
        for format in MeshFileFormat::ALL {
            let record = completed(&liar, &hash);
            let cluster = One(liar.clone());
            let refused = downloads.mesh(&record, Which::Result, format, "m", &cluster);
            let error = refused.await.err().expect("a lying host's mesh is never served");
            assert!(matches!(error, DownloadError::HashMismatch { .. }), "{format:?}: {error}");
            let api = meshflow_api::server::ApiError::from(error);
            assert_eq!((api.status.as_u16(), api.code), (502, "hash-mismatch"));
        }
        // The arrays right, anything else wrong: PLY, OBJ, OFF and STL are written here.
        let raw = honest.clone();
        let half_liar = host(move |format| match format {
            MeshFileFormat::Raw => Body::from(raw.clone()),
            _ => Body::from("ply\nnot the mesh at all"),
        })
        .await;
        let record = completed(&half_liar, &hash);
        let cluster = One(half_liar.clone());
        let obj = downloads.mesh(&record, Which::Result, MeshFileFormat::Obj, "m", &cluster);
        let obj = std::fs::read_to_string(obj.await.unwrap().file).unwrap();
        assert_eq!(obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        let stl = downloads.mesh(&record, Which::Result, MeshFileFormat::Stl, "m", &cluster);
        let stl = stl.await.unwrap();
        assert_eq!(stl.bytes, 84 + 50);
        let off = downloads.mesh(&record, Which::Result, MeshFileFormat::Off, "m", &cluster);
        let off = std::fs::read_to_string(off.await.unwrap().file).unwrap();
        assert_eq!(off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        drop(stl);
        let left = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(left, 0, "spool files go with their downloads");
    }

    fn rss() -> u64 {
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
        line.split_whitespace().nth(1).unwrap().parse::<u64>().unwrap() * 1024
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_1_gib_convert_answer_goes_to_disk_not_memory() {
        let (_, hash) = triangle(0.0);
        let dir = tempfile::tempdir().unwrap();
        let downloads = Downloads::spooling_in(dir.path().to_owned());
        // A raw header claiming one triangle, then 1 GiB of junk.
        let huge = host(|_| {
            let mut head = MAGIC.to_vec();
            head.extend([3u32, 1].iter().flat_map(|v| v.to_le_bytes()));
            let junk = Bytes::from(vec![7u8; 1 << 20]);
            let chunks =
                std::iter::once(Bytes::from(head)).chain((0..1024).map(move |_| junk.clone()));
            Body::from_stream(futures_util::stream::iter(chunks.map(Ok::<_, std::io::Error>)))
        })
        .await;
        let before = rss();
        let record = completed(&huge, &hash);
        let cluster = One(huge.clone());
        let error = downloads.mesh(&record, Which::Result, MeshFileFormat::Ply, "m", &cluster);
        let error = error.await.err().expect("not a mesh of one triangle");
        let grown = rss().saturating_sub(before);
        eprintln!("engine RSS grew by {} MB over a 1 GiB answer", grown >> 20);
        assert!(
            matches!(error, DownloadError::Spool { .. } | DownloadError::Corrupt { .. }),
            "{error}"
        );
        assert!(grown < 100 << 20, "RSS grew by {} MB", grown >> 20);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
