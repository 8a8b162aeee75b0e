// TEMPORARY profiling harness (not to be committed).
use meshflow_host::generate::{ScanSpec, scan};
use meshflow_host::store::{MeshStore, Op};
use meshflow_host::{MeshData, correction};
use std::time::Instant;

fn smooth(mesh: &MeshData, noise: bool) -> Vec<f32> {
    let n = mesh.vertex_count();
    let mut nb = vec![Vec::new(); n];
    for t in mesh.triangles.chunks_exact(3) {
        for k in 0..3 { nb[t[k] as usize].extend([t[(k+1)%3], t[(k+2)%3]]); }
    }
    let mut out = mesh.positions.clone();
    let mut s = 1u64;
    for v in 0..n {
        let l = &mut nb[v]; l.sort_unstable(); l.dedup();
        if l.is_empty() { continue; }
        for k in 0..3 {
            let sum: f64 = l.iter().map(|&u| f64::from(mesh.positions[3*u as usize+k])).sum();
            let mut q = (sum / l.len() as f64) as f32;
            if noise { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); q = f32::from_bits(q.to_bits().wrapping_add(((s>>40) as u32) & 0x3fff)); }
            out[3*v+k] = q;
        }
    }
    out
}

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let mesh = scan(&ScanSpec { vertices: 1_000_000, components: 150, holes: 40, noise: 0.2, seed: 11 });
    let mut store = MeshStore::new(mesh.clone());
    store.apply(Op::SetPositions { xyz: smooth(&mesh, mode == "noise") }).unwrap();
    let (result, log) = store.finish();
    let t = Instant::now();
    let bytes = correction::encode(&mesh, &log, &result).unwrap();
    eprintln!("encode {:?} {} B", t.elapsed(), bytes.len());
    for _ in 0..20 {
        let t = Instant::now();
        let r = correction::apply(&mesh, &bytes).unwrap();
        eprintln!("apply {:?}", t.elapsed());
        assert_eq!(r.triangles.len(), result.triangles.len());
    }
    let t = Instant::now(); let h = mesh.content_hash(); eprintln!("hash {:?} {}", t.elapsed(), h.0[0]);
    let t = Instant::now(); let c = mesh.clone(); eprintln!("clone {:?} {}", t.elapsed(), c.positions.len());
}
