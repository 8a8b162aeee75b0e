//! The C types of `plugin.h`, laid out as the generated header lays them out, and the
//! memory rules of the canonical ABI on the guest's side: what this library hands over is
//! `malloc`ed (the bindings' free helpers and `meshflow.hpp` release it with `free`), an
//! empty string or list is a null pointer with length 0 (the helpers free only a non-empty
//! one).

use std::ffi::c_void;
use std::panic::{AssertUnwindSafe, catch_unwind};

use meshflow_params::Value;

unsafe extern "C" {
    fn malloc(size: usize) -> *mut c_void;
    fn free(ptr: *mut c_void);
}

/// `plugin_string_t`: UTF-8 bytes, not NUL-terminated.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Str {
    pub ptr: *mut u8,
    pub len: usize,
}

/// `plugin_list_*_t` and the other `{ptr, len}` lists.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct List<T> {
    pub ptr: *mut T,
    pub len: usize,
}

/// `meshflow_geometry_types_value_t`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CValue {
    pub tag: u8,
    pub val: ValueUnion,
}

#[repr(C)]
#[derive(Clone, Copy)]
pub union ValueUnion {
    pub boolean: bool,
    pub integer: i64,
    pub real: f64,
    pub text: Str,
}

pub const TAG_BOOLEAN: u8 = 0;
pub const TAG_INTEGER: u8 = 1;
pub const TAG_REAL: u8 = 2;
pub const TAG_TEXT: u8 = 3;

/// `plugin_option_f64_t`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct OptionF64 {
    pub is_some: bool,
    pub val: f64,
}

/// `meshflow_geometry_types_option_value_type_t`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct OptionValueType {
    pub is_some: bool,
    pub val: u8,
}

/// `meshflow_geometry_types_param_info_t`.
#[repr(C)]
pub struct ParamInfo {
    pub name: Str,
    pub doc: Str,
    pub ty: u8,
    pub default: CValue,
    pub min: OptionF64,
    pub max: OptionF64,
    pub choices: List<Str>,
}

/// `meshflow_geometry_types_service_info_t`.
#[repr(C)]
pub struct ServiceInfo {
    pub name: Str,
    pub kind: u8,
    pub doc: Str,
    pub params: List<ParamInfo>,
    pub result_type: OptionValueType,
}

pub const KIND_CHECK: u8 = 1;

/// `meshflow_geometry_types_param_t`.
#[repr(C)]
pub struct Param {
    pub name: Str,
    pub value: CValue,
}

/// `meshflow_geometry_types_option_value_t`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct OptionValue {
    pub is_some: bool,
    pub val: CValue,
}

/// `meshflow_geometry_types_outcome_t`.
#[repr(C)]
pub struct Outcome {
    pub value: OptionValue,
    pub report: Str,
}

/// `meshflow_geometry_types_edit_error_t`.
#[repr(C)]
pub struct EditError {
    pub kind: u8,
    pub message: Str,
}

/// `meshflow_geometry_mesh_borrow_mesh_t` (and `own_mesh_t`): a run's mesh, by number.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct Handle {
    pub handle: i32,
}

/// `plugin_tuple3_f32_f32_f32_t`.
#[repr(C)]
pub struct Tuple3F32 {
    pub f0: f32,
    pub f1: f32,
    pub f2: f32,
}

/// `plugin_tuple3_u32_u32_u32_t`.
#[repr(C)]
pub struct Tuple3U32 {
    pub f0: u32,
    pub f1: u32,
    pub f2: u32,
}

/// `meshflow_geometry_mesh_component_t`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Component {
    pub first_triangle: u32,
    pub triangles: u32,
}

/// `meshflow_geometry_mesh_attribute_info_t`.
#[repr(C)]
pub struct AttributeInfo {
    pub domain: u8,
    pub name: Str,
    pub components: u8,
    pub number_type: u8,
}

/// `meshflow_geometry_mesh_attribute_values_t`: a tag and a union of `{ptr, len}` lists,
/// which all share one layout, so the list is kept untyped and read by its tag.
#[repr(C)]
pub struct AttributeValues {
    pub tag: u8,
    pub list: List<std::ffi::c_void>,
}

/// The tags of [`AttributeValues`] and the codes of `number-type`, in the WIT's order.
pub const NUMBER_U8: u8 = 0;
pub const NUMBER_S32: u8 = 1;
pub const NUMBER_U32: u8 = 2;
pub const NUMBER_F32: u8 = 3;
pub const NUMBER_F64: u8 = 4;

/// `plugin_option_list_u32_t`, `plugin_option_list_f32_t`.
#[repr(C)]
pub struct OptionList<T> {
    pub is_some: bool,
    pub val: List<T>,
}

/// The `{bool is_err; union {T ok; E err;}}` results of `plugin.h`.
#[repr(C)]
pub struct CResult<T, E> {
    pub is_err: bool,
    pub val: ResultUnion<T, E>,
}

#[repr(C)]
pub union ResultUnion<T, E> {
    pub ok: std::mem::ManuallyDrop<T>,
    pub err: std::mem::ManuallyDrop<E>,
}

/// `meshflow_geometry_mesh_result_void_edit_error_t`: its union holds only the error.
#[repr(C)]
pub struct CResultVoid {
    pub is_err: bool,
    pub err: EditError,
}

/// The plugin's exported `describe`.
pub type DescribeFn = unsafe extern "C" fn(ret: *mut List<ServiceInfo>);
/// The plugin's exported `run`.
pub type RunFn = unsafe extern "C" fn(
    name: *mut Str,
    target: Handle,
    params: *mut List<Param>,
    ret: *mut Outcome,
    err: *mut Str,
) -> bool;

// ---- memory -----------------------------------------------------------------------------

/// `items`, copied into `malloc`ed memory; null for none.
pub fn c_copy<T: Copy>(items: &[T]) -> List<T> {
    if items.is_empty() {
        return List { ptr: std::ptr::null_mut(), len: 0 };
    }
    let bytes = std::mem::size_of_val(items);
    // SAFETY: malloc has no preconditions; its result is checked before use.
    let ptr = unsafe { malloc(bytes) }.cast::<T>();
    if ptr.is_null() {
        std::alloc::handle_alloc_error(std::alloc::Layout::for_value(items));
    }
    // SAFETY: `ptr` holds `bytes` fresh bytes, suitably aligned for any type (malloc), and
    // cannot overlap `items`.
    unsafe { std::ptr::copy_nonoverlapping(items.as_ptr(), ptr, items.len()) };
    List { ptr, len: items.len() }
}

/// `items`, moved into `malloc`ed memory; null for none.
pub fn c_list<T>(items: Vec<T>) -> List<T> {
    if items.is_empty() {
        return List { ptr: std::ptr::null_mut(), len: 0 };
    }
    let layout = std::alloc::Layout::array::<T>(items.len()).expect("a list that fits memory");
    // SAFETY: malloc has no preconditions; its result is checked before use.
    let ptr = unsafe { malloc(layout.size()) }.cast::<T>();
    if ptr.is_null() {
        std::alloc::handle_alloc_error(layout);
    }
    let len = items.len();
    for (i, item) in items.into_iter().enumerate() {
        // SAFETY: `ptr` holds room for `len` values of T, suitably aligned (malloc).
        unsafe { ptr.add(i).write(item) };
    }
    List { ptr, len }
}

/// A `malloc`ed copy of `text`; null for "".
pub fn c_string(text: &str) -> Str {
    let List { ptr, len } = c_copy(text.as_bytes());
    Str { ptr, len }
}

/// Frees what [`c_copy`], [`c_list`] or the C side allocated (null is fine).
pub fn c_free<T>(ptr: *mut T) {
    // SAFETY: `ptr` is null or came from malloc (this file's helpers or the C side's, which
    // share the C library's heap), and the caller no longer uses it.
    unsafe { free(ptr.cast()) }
}

/// Frees a string the C side or [`c_string`] allocated, as `plugin_string_free` does.
pub fn free_string(s: &mut Str) {
    if s.len > 0 {
        c_free(s.ptr);
    }
    *s = Str { ptr: std::ptr::null_mut(), len: 0 };
}

/// The elements a C list points to.
///
/// # Safety
/// `ptr` is null or points to `len` initialised values that live for `'a` and are not
/// written meanwhile.
pub unsafe fn slice<'a, T>(ptr: *const T, len: usize) -> Option<&'a [T]> {
    if len == 0 {
        return Some(&[]);
    }
    if ptr.is_null() || len.checked_mul(std::mem::size_of::<T>())? > isize::MAX as usize {
        return None;
    }
    // SAFETY: non-null, within isize::MAX bytes, and the caller vouches for the rest.
    Some(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// A C string's text (invalid UTF-8 replaced, as a message to show).
///
/// # Safety
/// As [`slice`] for the string's bytes.
pub unsafe fn read_str(s: &Str) -> Option<String> {
    // SAFETY: the caller's promise, passed on.
    let bytes = unsafe { slice(s.ptr, s.len) }?;
    Some(String::from_utf8_lossy(bytes).into_owned())
}

/// A C value as a meshflow value; `None` for a tag the WIT does not have.
///
/// # Safety
/// A text value's string is as [`read_str`] needs.
pub unsafe fn read_value(v: &CValue) -> Option<Value> {
    // SAFETY: each arm reads the union field its tag says was written.
    unsafe {
        Some(match v.tag {
            TAG_BOOLEAN => Value::Boolean(v.val.boolean),
            TAG_INTEGER => Value::Integer(v.val.integer),
            TAG_REAL => Value::Real(v.val.real),
            TAG_TEXT => Value::Text(read_str(&v.val.text)?),
            _ => return None,
        })
    }
}

/// A meshflow value as a C value; a text is `malloc`ed.
pub fn c_value(value: &Value) -> CValue {
    match value {
        Value::Boolean(b) => CValue { tag: TAG_BOOLEAN, val: ValueUnion { boolean: *b } },
        Value::Integer(i) => CValue { tag: TAG_INTEGER, val: ValueUnion { integer: *i } },
        Value::Real(r) => CValue { tag: TAG_REAL, val: ValueUnion { real: *r } },
        Value::Text(t) => CValue { tag: TAG_TEXT, val: ValueUnion { text: c_string(t) } },
    }
}

// ---- traps and panics -------------------------------------------------------------------

/// Ends the process where a host would trap the plugin: the test must not go on.
pub fn trap(message: &str) -> ! {
    eprintln!("meshflow native: {message} (a host would stop this plugin here)");
    std::process::abort()
}

/// Runs `f`, turning a panic of this library into a trap: nothing unwinds into C.
pub fn shielded<T>(call: &str, f: impl FnOnce() -> T) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(value) => value,
        Err(panic) => trap(&format!("{call}: internal error: {}", panic_text(&*panic))),
    }
}

/// What a panic said.
pub fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    match (panic.downcast_ref::<&str>(), panic.downcast_ref::<String>()) {
        (Some(text), _) => (*text).to_owned(),
        (_, Some(text)) => text.clone(),
        _ => "a panic".to_owned(),
    }
}
