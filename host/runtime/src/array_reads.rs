//! The mesh's bulk reads lowered straight out of the host's own arrays: `positions` and
//! `triangles` from the run's store, and the derived connectivity (`half-edge-opposites`,
//! `half-edge-kinds`, `edges`) from the [`ConnectivityCache`].
//!
//! `bindgen!` has host functions return a `list` as an owned `Vec`, which wasmtime then
//! copies into the guest: two copies of the mesh where one suffices (on a 1M-vertex scan,
//! 36 MB and about 4 ms of every run). [`add_to_linker`] redefines these functions to
//! return a [`SharedArray`], which lowers exactly as the slice it names would.
//!
//! [`ConnectivityCache`]: crate::connectivity_cache::ConnectivityCache

use std::mem::MaybeUninit;
use std::sync::Arc;

use wasmtime::StoreContextMut;
use wasmtime::component::__internal::{
    CanonicalAbiInfo, InstanceType, InterfaceType, LowerContext,
};
use wasmtime::component::{ComponentType, Linker, Lower, Resource};

use super::state::{MeshHandle, RunState};
use meshflow_topology::Connectivity;

/// The `meshflow:geometry` interface these functions belong to, as the linker names it.
const MESH_INTERFACE: &str = "meshflow:geometry/mesh@0.1.0";

/// One array of a shared owner (the run's mesh, or its connectivity), held by an `Arc`
/// clone for the moment it is lowered: the clone is dropped before the guest's next call,
/// so an edit still finds the store's copy unshared.
struct SharedArray<O: 'static, T: 'static> {
    owner: Arc<O>,
    array: fn(&O) -> &[T],
}

// SAFETY: every item is `[T]`'s own, as wasmtime's impls for `Vec<T>` and `Arc<[T]>` do.
unsafe impl<O: Send + Sync + 'static, T: ComponentType + 'static> ComponentType
    for SharedArray<O, T>
{
    type Lower = <[T] as ComponentType>::Lower;
    const ABI: CanonicalAbiInfo = <[T] as ComponentType>::ABI;

    fn typecheck(ty: &InterfaceType, types: &InstanceType<'_>) -> wasmtime::Result<()> {
        <[T] as ComponentType>::typecheck(ty, types)
    }
}

// SAFETY: lowers the slice with `[T]`'s own implementation.
unsafe impl<O: Send + Sync + 'static, T: Lower + 'static> Lower for SharedArray<O, T> {
    fn linear_lower_to_flat<U>(
        &self,
        cx: &mut LowerContext<'_, U>,
        ty: InterfaceType,
        dst: &mut MaybeUninit<Self::Lower>,
    ) -> wasmtime::Result<()> {
        (self.array)(&self.owner).linear_lower_to_flat(cx, ty, dst)
    }

    fn linear_lower_to_memory<U>(
        &self,
        cx: &mut LowerContext<'_, U>,
        ty: InterfaceType,
        offset: usize,
    ) -> wasmtime::Result<()> {
        (self.array)(&self.owner).linear_lower_to_memory(cx, ty, offset)
    }
}

/// Redefines the bulk reads, which the generated `add_to_linker` defined with `HostMesh`'s
/// methods, to lower from the store or the cache. Shadowing is allowed for these
/// definitions only.
pub(crate) fn add_to_linker(linker: &mut Linker<RunState>) -> wasmtime::Result<()> {
    let slots = |state: &RunState| state.mesh.shared_slots();
    linker.allow_shadowing(true);
    let defined = (|| {
        let mut mesh = linker.instance(MESH_INTERFACE)?;
        mesh.func_wrap("[method]mesh.positions", lowered(slots, |m| &m.positions))?;
        mesh.func_wrap("[method]mesh.triangles", lowered(slots, |m| &m.triangles))?;
        mesh.func_wrap(
            "[method]mesh.half-edge-opposites",
            lowered(connectivity, Connectivity::opposites),
        )?;
        mesh.func_wrap(
            "[method]mesh.half-edge-kinds",
            lowered(connectivity, Connectivity::kind_codes),
        )?;
        mesh.func_wrap("[method]mesh.edges", lowered(connectivity, Connectivity::edges))
    })();
    linker.allow_shadowing(false);
    defined
}

/// The method's one argument, the mesh handle (a run has one mesh, so it is not looked at).
type Args = (Resource<MeshHandle>,);

/// A bulk read: `array` of what `owner` shares from the run's state, lowered as it is.
fn lowered<O: Send + Sync + 'static, T: Lower + 'static>(
    owner: fn(&RunState) -> Arc<O>,
    array: fn(&O) -> &[T],
) -> impl Fn(StoreContextMut<'_, RunState>, Args) -> wasmtime::Result<(SharedArray<O, T>,)>
+ Send
+ Sync
+ 'static {
    move |store, _| Ok((SharedArray { owner: owner(store.data()), array },))
}
/// The connectivity of the run's mesh: a read-only run's mesh is the caller's version, kept
/// in the cache; a run that edits gets its current state derived afresh, never cached (a
/// `Weak` to its own copy would make the store copy the mesh again at its next edit).
fn connectivity(state: &RunState) -> Arc<Connectivity> {
    let mesh = state.mesh.shared_slots();
    match state.read_only {
        true => state.connectivity.get(&mesh),
        false => Arc::new(state.connectivity.derive(&mesh)),
    }
}
