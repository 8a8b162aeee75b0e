//! The triangles around each vertex, built on the first topological edit of a step and kept
//! up to date after it, so steps that only move vertices never pay for it.

/// Live triangles per vertex slot. Lists are unordered; callers that need a canonical order
/// (anything that appends new elements) sort what they take.
#[derive(Default)]
pub(crate) struct Incidence {
    lists: Vec<Vec<u32>>,
}

impl Incidence {
    pub(crate) fn build(vertex_slots: usize, triangles: &[u32]) -> Self {
        let mut counts = vec![0u32; vertex_slots];
        for &v in triangles.iter().filter(|&&v| v != super::REMOVED) {
            counts[v as usize] += 1;
        }
        let mut lists: Vec<Vec<u32>> =
            counts.iter().map(|&n| Vec::with_capacity(n as usize)).collect();
        for (t, corners) in triangles.chunks_exact(3).enumerate() {
            if corners[0] == super::REMOVED {
                continue;
            }
            for (k, &v) in corners.iter().enumerate() {
                // A degenerate input triangle lists its repeated vertex once.
                if !corners[..k].contains(&v) {
                    lists[v as usize].push(t as u32);
                }
            }
        }
        Self { lists }
    }

    pub(crate) fn around(&self, vertex: u32) -> &[u32] {
        &self.lists[vertex as usize]
    }

    pub(crate) fn add_vertex(&mut self) {
        self.lists.push(Vec::new());
    }

    pub(crate) fn add_triangle(&mut self, t: u32, corners: [u32; 3]) {
        for (k, &v) in corners.iter().enumerate() {
            if !corners[..k].contains(&v) {
                self.lists[v as usize].push(t);
            }
        }
    }

    pub(crate) fn remove_triangle(&mut self, t: u32, corners: [u32; 3]) {
        for v in corners {
            let list = &mut self.lists[v as usize];
            if let Some(i) = list.iter().position(|&x| x == t) {
                list.swap_remove(i);
            }
        }
    }
}
