//! The mesh's bulk reads (`positions`, `triangles`) lowered straight out of the run's store.
//!
//! `bindgen!` has host functions return a `list` as an owned `Vec`, which wasmtime then
//! copies into the guest: two copies of the mesh where one suffices (on a 1M-vertex scan,
//! 36 MB and about 4 ms of every run). [`add_to_linker`] redefines the two functions to
//! return a [`MeshArray`], which lowers exactly as the slice it names would, from the store's
//! own array.

use std::mem::MaybeUninit;
use std::sync::Arc;

use wasmtime::StoreContextMut;
use wasmtime::component::__internal::{
    CanonicalAbiInfo, InstanceType, InterfaceType, LowerContext,
};
use wasmtime::component::{ComponentType, Linker, Lower, Resource};

use super::state::{MeshHandle, RunState};
use meshflow_mesh::MeshData;

/// The `meshflow:geometry` interface these functions belong to, as the linker names it.
const MESH_INTERFACE: &str = "meshflow:geometry/mesh@0.1.0";

/// One of the arrays of a run's mesh, held by an `Arc` clone for the moment it is lowered:
/// the clone is dropped before the guest's next call, so an edit still finds the store's
/// copy unshared.
struct MeshArray<T: 'static> {
    mesh: Arc<MeshData>,
    array: fn(&MeshData) -> &[T],
}

// SAFETY: every item is `[T]`'s own, as wasmtime's impls for `Vec<T>` and `Arc<[T]>` do.
unsafe impl<T: ComponentType + 'static> ComponentType for MeshArray<T> {
    type Lower = <[T] as ComponentType>::Lower;
    const ABI: CanonicalAbiInfo = <[T] as ComponentType>::ABI;

    fn typecheck(ty: &InterfaceType, types: &InstanceType<'_>) -> wasmtime::Result<()> {
        <[T] as ComponentType>::typecheck(ty, types)
    }
}

// SAFETY: lowers the slice with `[T]`'s own implementation.
unsafe impl<T: Lower + 'static> Lower for MeshArray<T> {
    fn linear_lower_to_flat<U>(
        &self,
        cx: &mut LowerContext<'_, U>,
        ty: InterfaceType,
        dst: &mut MaybeUninit<Self::Lower>,
    ) -> wasmtime::Result<()> {
        (self.array)(&self.mesh).linear_lower_to_flat(cx, ty, dst)
    }

    fn linear_lower_to_memory<U>(
        &self,
        cx: &mut LowerContext<'_, U>,
        ty: InterfaceType,
        offset: usize,
    ) -> wasmtime::Result<()> {
        (self.array)(&self.mesh).linear_lower_to_memory(cx, ty, offset)
    }
}

/// Redefines `[method]mesh.positions` and `[method]mesh.triangles`, which the generated
/// `add_to_linker` defined with `HostMesh`'s methods, to lower from the store. Shadowing is
/// allowed for these two definitions only.
pub(crate) fn add_to_linker(linker: &mut Linker<RunState>) -> wasmtime::Result<()> {
    fn read<T: Lower + 'static>(
        array: fn(&MeshData) -> &[T],
    ) -> impl Fn(
        StoreContextMut<'_, RunState>,
        (Resource<MeshHandle>,),
    ) -> wasmtime::Result<(MeshArray<T>,)>
    + Send
    + Sync
    + 'static {
        move |store, _| Ok((MeshArray { mesh: store.data().mesh.shared_slots(), array },))
    }
    linker.allow_shadowing(true);
    let defined = (|| {
        let mut mesh = linker.instance(MESH_INTERFACE)?;
        mesh.func_wrap("[method]mesh.positions", read(|m| &m.positions))?;
        mesh.func_wrap("[method]mesh.triangles", read(|m| &m.triangles))
    })();
    linker.allow_shadowing(false);
    defined
}
