//! The free and string helpers `plugin.h` declares, as the generated `plugin.c` defines them
//! (which, calling wasm imports, cannot be compiled for the host's CPU): each frees what its
//! value owns (`free` for non-empty strings and lists) and leaves the value itself to the
//! caller. Every pointer is a valid value of its type, or null (then nothing happens).

use crate::abi::{
    AttributeInfo, AttributeValues, CResult, CResultVoid, CValue, Component, EditError, List,
    OptionF64, OptionList, OptionValue, OptionValueType, Outcome, Param, ParamInfo, ServiceInfo,
    Str, TAG_TEXT, Tuple3F32, Tuple3U32, c_free, free_string, trap,
};

/// The elements of a list, to free each, then the list's memory.
///
/// # Safety
/// `list` is a valid list whose `len` elements are initialised and owned.
unsafe fn free_list<T>(list: *mut List<T>, each: impl Fn(*mut T)) {
    // SAFETY: null is allowed; otherwise the caller's promise.
    let Some(list) = (unsafe { list.as_mut() }) else { return };
    if list.len > 0 {
        for i in 0..list.len {
            // SAFETY: `i < len`, within the list's memory.
            each(unsafe { list.ptr.add(i) });
        }
        c_free(list.ptr);
    }
    list.ptr = std::ptr::null_mut();
    list.len = 0;
}

/// # Safety
/// `ptr` is null or a valid string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_string_free(ptr: *mut Str) {
    // SAFETY: null is allowed; otherwise the caller's promise.
    if let Some(s) = unsafe { ptr.as_mut() } {
        free_string(s);
    }
}

/// Points `ret` at `s` without a copy (the string is not freed with it).
///
/// # Safety
/// `ret` is writable; `s` is a NUL-terminated string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_string_set(ret: *mut Str, s: *const std::ffi::c_char) {
    if ret.is_null() || s.is_null() {
        trap("plugin_string_set: a null pointer");
    }
    // SAFETY: checked for null; the caller's promise otherwise.
    unsafe {
        let len = std::ffi::CStr::from_ptr(s).to_bytes().len();
        ret.write(Str { ptr: s.cast_mut().cast(), len });
    }
}

/// A `malloc`ed copy of the NUL-terminated `s`.
///
/// # Safety
/// `ret` is writable; `s` is a NUL-terminated string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_string_dup(ret: *mut Str, s: *const std::ffi::c_char) {
    if ret.is_null() || s.is_null() {
        trap("plugin_string_dup: a null pointer");
    }
    // SAFETY: checked for null; the caller's promise otherwise.
    unsafe {
        let bytes = std::ffi::CStr::from_ptr(s).to_bytes();
        let List { ptr, len } = crate::abi::c_copy(bytes);
        ret.write(Str { ptr, len });
    }
}

/// A `malloc`ed copy of `len` bytes at `s`.
///
/// # Safety
/// `ret` is writable; `s` holds `len` readable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_string_dup_n(
    ret: *mut Str,
    s: *const std::ffi::c_char,
    len: usize,
) {
    // SAFETY: the caller's promise; `slice` checks null against the length.
    let bytes = unsafe { crate::abi::slice(s.cast::<u8>(), len) };
    let (Some(bytes), false) = (bytes, ret.is_null()) else {
        trap("plugin_string_dup_n: a null pointer");
    };
    let List { ptr, len } = crate::abi::c_copy(bytes);
    // SAFETY: checked for null; the caller's promise otherwise.
    unsafe { ret.write(Str { ptr, len }) }
}

/// # Safety
/// `ptr` is null or a valid value.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_value_free(ptr: *mut CValue) {
    // SAFETY: null is allowed; a text's tag says its string was written.
    unsafe {
        if let Some(v) = ptr.as_mut()
            && v.tag == TAG_TEXT
        {
            free_string(&mut v.val.text);
        }
    }
}

/// Nothing to free in an option of a number.
#[unsafe(no_mangle)]
pub extern "C" fn plugin_option_f64_free(_ptr: *mut OptionF64) {}

/// # Safety
/// `ptr` is null or a valid list of strings.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_string_free(ptr: *mut List<Str>) {
    // SAFETY: the caller's promise; each element is a string.
    unsafe { free_list(ptr, |s| plugin_string_free(s)) }
}

/// # Safety
/// `ptr` is null or a valid parameter description.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_param_info_free(ptr: *mut ParamInfo) {
    // SAFETY: null is allowed; otherwise each field is a valid value of its type.
    unsafe {
        let Some(p) = ptr.as_mut() else { return };
        free_string(&mut p.name);
        free_string(&mut p.doc);
        meshflow_geometry_types_value_free(&mut p.default);
        plugin_list_string_free(&mut p.choices);
    }
}

/// # Safety
/// `ptr` is null or a valid list of parameter descriptions.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_list_param_info_free(ptr: *mut List<ParamInfo>) {
    // SAFETY: the caller's promise; each element is a parameter description.
    unsafe { free_list(ptr, |p| meshflow_geometry_types_param_info_free(p)) }
}

/// Nothing to free in an option of a type.
#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_types_option_value_type_free(_ptr: *mut OptionValueType) {}

/// # Safety
/// `ptr` is null or a valid service description.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_service_info_free(ptr: *mut ServiceInfo) {
    // SAFETY: null is allowed; otherwise each field is a valid value of its type.
    unsafe {
        let Some(s) = ptr.as_mut() else { return };
        free_string(&mut s.name);
        free_string(&mut s.doc);
        meshflow_geometry_types_list_param_info_free(&mut s.params);
    }
}

/// # Safety
/// `ptr` is null or a valid parameter.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_param_free(ptr: *mut Param) {
    // SAFETY: null is allowed; otherwise each field is a valid value of its type.
    unsafe {
        let Some(p) = ptr.as_mut() else { return };
        free_string(&mut p.name);
        meshflow_geometry_types_value_free(&mut p.value);
    }
}

/// # Safety
/// `ptr` is null or a valid optional value.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_option_value_free(ptr: *mut OptionValue) {
    // SAFETY: null is allowed; the value is written when `is_some`.
    unsafe {
        if let Some(o) = ptr.as_mut()
            && o.is_some
        {
            meshflow_geometry_types_value_free(&mut o.val);
        }
    }
}

/// # Safety
/// `ptr` is null or a valid outcome.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_outcome_free(ptr: *mut Outcome) {
    // SAFETY: null is allowed; otherwise each field is a valid value of its type.
    unsafe {
        let Some(o) = ptr.as_mut() else { return };
        meshflow_geometry_types_option_value_free(&mut o.value);
        free_string(&mut o.report);
    }
}

/// # Safety
/// `ptr` is null or a valid edit error.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_types_edit_error_free(ptr: *mut EditError) {
    // SAFETY: null is allowed; otherwise the message is a valid string.
    if let Some(e) = unsafe { ptr.as_mut() } {
        free_string(&mut e.message);
    }
}

/// # Safety
/// `ptr` is null or a valid edit error.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_edit_error_free(ptr: *mut EditError) {
    // SAFETY: the caller's promise, passed on.
    unsafe { meshflow_geometry_types_edit_error_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_f32_free(ptr: *mut List<f32>) {
    // SAFETY: the caller's promise; numbers own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_u32_free(ptr: *mut List<u32>) {
    // SAFETY: the caller's promise; numbers own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_u8_free(ptr: *mut List<u8>) {
    // SAFETY: the caller's promise; numbers own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_s32_free(ptr: *mut List<i32>) {
    // SAFETY: the caller's promise; numbers own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_list_f64_free(ptr: *mut List<f64>) {
    // SAFETY: the caller's promise; numbers own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// Frees an optional list's list, if it has one.
///
/// # Safety
/// `ptr` is null or a valid option.
unsafe fn free_option_list<T>(ptr: *mut OptionList<T>, free: unsafe extern "C" fn(*mut List<T>)) {
    // SAFETY: null is allowed; the list is written when `is_some`.
    unsafe {
        if let Some(option) = ptr.as_mut()
            && option.is_some
        {
            free(&mut option.val);
        }
    }
}

/// # Safety
/// `ptr` is null or a valid option.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_option_list_u32_free(ptr: *mut OptionList<u32>) {
    // SAFETY: the caller's promise.
    unsafe { free_option_list(ptr, plugin_list_u32_free) }
}

/// # Safety
/// `ptr` is null or a valid option.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_option_list_f32_free(ptr: *mut OptionList<f32>) {
    // SAFETY: the caller's promise.
    unsafe { free_option_list(ptr, plugin_list_f32_free) }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_list_component_free(ptr: *mut List<Component>) {
    // SAFETY: the caller's promise; components are numbers and own nothing.
    unsafe { free_list(ptr, |_| ()) }
}

/// # Safety
/// `ptr` is null or a valid attribute description.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_attribute_info_free(ptr: *mut AttributeInfo) {
    // SAFETY: null is allowed; otherwise the caller's promise.
    if let Some(info) = unsafe { ptr.as_mut() } {
        free_string(&mut info.name);
    }
}

/// # Safety
/// `ptr` is null or a valid list.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_list_attribute_info_free(
    ptr: *mut List<AttributeInfo>,
) {
    // SAFETY: the caller's promise; each element is freed as its type is.
    unsafe { free_list(ptr, |info| meshflow_geometry_mesh_attribute_info_free(info)) }
}

/// Frees the list whatever its tag: every list of the union has the same layout and owns
/// plain numbers.
///
/// # Safety
/// `ptr` is null or a valid variant.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_attribute_values_free(ptr: *mut AttributeValues) {
    // SAFETY: null is allowed; otherwise the caller's promise.
    if let Some(values) = unsafe { ptr.as_mut() } {
        if values.list.len > 0 {
            c_free(values.list.ptr);
        }
        values.list = List { ptr: std::ptr::null_mut(), len: 0 };
    }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_result_attribute_values_edit_error_free(
    ptr: *mut CResult<AttributeValues, EditError>,
) {
    // SAFETY: null is allowed; the field `is_err` names is the one written.
    unsafe {
        match ptr.as_mut() {
            Some(r) if r.is_err => meshflow_geometry_types_edit_error_free(&mut *r.val.err),
            Some(r) => meshflow_geometry_mesh_attribute_values_free(&mut *r.val.ok),
            None => {}
        }
    }
}

/// The error of a result, when it is one.
///
/// # Safety
/// `ptr` is null or a valid result whose `is_err` says which field was written.
unsafe fn free_result_error<T>(ptr: *mut CResult<T, EditError>) {
    // SAFETY: the caller's promise; the error field is read only when `is_err`.
    unsafe {
        if let Some(r) = ptr.as_mut()
            && r.is_err
        {
            meshflow_geometry_types_edit_error_free(&mut *r.val.err);
        }
    }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_result_tuple3_f32_f32_f32_edit_error_free(
    ptr: *mut CResult<Tuple3F32, EditError>,
) {
    // SAFETY: the caller's promise.
    unsafe { free_result_error(ptr) }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_result_tuple3_u32_u32_u32_edit_error_free(
    ptr: *mut CResult<Tuple3U32, EditError>,
) {
    // SAFETY: the caller's promise.
    unsafe { free_result_error(ptr) }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_result_u32_edit_error_free(
    ptr: *mut CResult<u32, EditError>,
) {
    // SAFETY: the caller's promise.
    unsafe { free_result_error(ptr) }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_result_void_edit_error_free(ptr: *mut CResultVoid) {
    // SAFETY: null is allowed; the error is written when `is_err`.
    unsafe {
        if let Some(r) = ptr.as_mut()
            && r.is_err
        {
            meshflow_geometry_types_edit_error_free(&mut r.err);
        }
    }
}

/// # Safety
/// `ptr` is null or a valid service description.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_service_info_free(
    ptr: *mut ServiceInfo,
) {
    // SAFETY: the caller's promise.
    unsafe { meshflow_geometry_types_service_info_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid parameter.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_param_free(ptr: *mut Param) {
    // SAFETY: the caller's promise.
    unsafe { meshflow_geometry_types_param_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid outcome.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_outcome_free(ptr: *mut Outcome) {
    // SAFETY: the caller's promise.
    unsafe { meshflow_geometry_types_outcome_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid list of service descriptions.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_list_service_info_free(
    ptr: *mut List<ServiceInfo>,
) {
    // SAFETY: the caller's promise; each element is a service description.
    unsafe { free_list(ptr, |s| meshflow_geometry_types_service_info_free(s)) }
}

/// # Safety
/// `ptr` is null or a valid list of parameters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_list_param_free(ptr: *mut List<Param>) {
    // SAFETY: the caller's promise; each element is a parameter.
    unsafe { free_list(ptr, |p| meshflow_geometry_types_param_free(p)) }
}

/// # Safety
/// `ptr` is null or a valid result.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_service_result_outcome_string_free(
    ptr: *mut CResult<Outcome, Str>,
) {
    // SAFETY: null is allowed; `is_err` says which field was written.
    unsafe {
        let Some(r) = ptr.as_mut() else { return };
        if r.is_err {
            free_string(&mut r.val.err);
        } else {
            meshflow_geometry_types_outcome_free(&mut *r.val.ok);
        }
    }
}

/// # Safety
/// `ptr` is null or a valid parameter.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_locality_param_free(ptr: *mut Param) {
    // SAFETY: the caller's promise.
    unsafe { meshflow_geometry_types_param_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid list of parameters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_locality_list_param_free(ptr: *mut List<Param>) {
    // SAFETY: the caller's promise.
    unsafe { exports_meshflow_geometry_service_list_param_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid parameter.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_blocks_param_free(ptr: *mut Param) {
    // SAFETY: the caller's promise.
    unsafe { meshflow_geometry_types_param_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid list of parameters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn exports_meshflow_geometry_blocks_list_param_free(ptr: *mut List<Param>) {
    // SAFETY: the caller's promise.
    unsafe { exports_meshflow_geometry_service_list_param_free(ptr) }
}

/// # Safety
/// `ptr` is null or a valid option; a number owns nothing.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn plugin_option_u32_free(_: *mut std::ffi::c_void) {}
