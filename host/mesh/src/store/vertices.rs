//! Vertex edits: add, move, move all, remove.

use std::sync::Arc;

use super::{EditError, MeshStore, check_distinct, check_finite, check_triples};
use crate::MeshData;

impl MeshStore {
    pub(super) fn add_vertices(&mut self, xyz: &[f32]) -> Result<u32, EditError> {
        check_triples(xyz.len(), "add-vertices")?;
        check_finite(xyz, "add-vertices")?;
        let first = self.vertex_slots();
        for p in xyz.chunks_exact(3) {
            self.push_vertex([p[0], p[1], p[2]], &[]);
        }
        Ok(first)
    }

    pub(super) fn move_vertices(&mut self, ids: &[u32], xyz: &[f32]) -> Result<(), EditError> {
        if xyz.len() != 3 * ids.len() {
            return Err(EditError::argument(format!(
                "move-vertices: {} ids need {} coordinates, got {}",
                ids.len(),
                3 * ids.len(),
                xyz.len()
            )));
        }
        check_finite(xyz, "move-vertices")?;
        for &v in ids {
            self.check_vertex(v)?;
        }
        ids.iter().for_each(|&v| self.touch(v));
        let positions = self.positions_mut();
        for (&v, p) in ids.iter().zip(xyz.chunks_exact(3)) {
            let i = 3 * v as usize;
            positions[i..i + 3].copy_from_slice(p);
        }
        Ok(())
    }

    /// Removed slots keep their positions whatever `xyz` says there; `apply` records the
    /// positions as they are afterwards, so the log never carries ignored values.
    pub(super) fn set_positions(&mut self, xyz: &[f32]) -> Result<(), EditError> {
        let expected = self.mesh.positions.len();
        if xyz.len() != expected {
            return Err(EditError::argument(format!(
                "set-positions: expected {expected} values (3 per vertex slot), got {}",
                xyz.len()
            )));
        }
        let bad = xyz
            .chunks_exact(3)
            .enumerate()
            .find(|&(v, p)| !self.vertex_removed[v] && p.iter().any(|c| !c.is_finite()));
        if let Some((v, p)) = bad {
            check_finite(p, &format!("set-positions, vertex {v}"))?;
        }
        if self.normals.is_some() {
            // Only vertices that really move change the normals around them.
            for v in 0..self.vertex_slots() {
                let i = 3 * v as usize;
                let moved =
                    (i..i + 3).any(|k| xyz[k].to_bits() != self.mesh.positions[k].to_bits());
                if self.is_vertex_live(v) && moved {
                    self.touch(v);
                }
            }
        }
        if self.removed_vertex_count == 0 {
            // Every slot takes its value: one copy, no per-vertex check, and a mesh still
            // shared with the caller is not copied first only to be overwritten.
            match Arc::get_mut(&mut self.mesh) {
                Some(mesh) => mesh.positions.copy_from_slice(xyz),
                None => {
                    let mut mesh = MeshData::new(xyz.to_vec(), self.mesh.triangles.clone());
                    mesh.attributes = self.mesh.attributes.clone();
                    self.mesh = Arc::new(mesh);
                }
            }
            return Ok(());
        }
        let positions = &mut super::owned(&mut self.mesh).positions;
        for (v, p) in xyz.chunks_exact(3).enumerate() {
            if !self.vertex_removed[v] {
                positions[3 * v..3 * v + 3].copy_from_slice(p);
            }
        }
        Ok(())
    }

    pub(super) fn remove_vertices(&mut self, ids: &[u32]) -> Result<(), EditError> {
        for &v in ids {
            self.check_vertex(v)?;
        }
        check_distinct(ids, "remove-vertices")?;
        for &v in ids {
            for t in self.triangles_around(v) {
                self.kill_triangle(t);
            }
            self.kill_vertex(v);
        }
        Ok(())
    }
}
