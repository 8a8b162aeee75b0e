/* meshflow_native.h: the native test backend of the C/C++ SDK (libmeshflow_native.so).
 *
 * Built for the host's CPU, the library implements every function of ../generated/plugin.h
 * except the plugin's two exports: the WIT mesh calls go to the host's own recording store,
 * so every edit is checked and recorded as a host does it. This header adds what a test
 * needs around a plugin: meshes from files (the host's readers) or arrays, and runs of a
 * service through the plugin's exported describe() and run(), as a host runs them.
 * meshflow.hpp wraps it all in C++ when MESHFLOW_NATIVE is defined (meshflow::native).
 *
 * Memory: strings and lists this library hands over are malloc'ed (the free helpers of
 * plugin.h and the functions below release them). A call a host would trap on (a null
 * pointer where data must be, a mesh handle of no run) aborts the process with a message. */
#ifndef MESHFLOW_NATIVE_H
#define MESHFLOW_NATIVE_H

#include "plugin.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A mesh held by the library: loaded, made from arrays, or a run's result. */
typedef struct meshflow_native_mesh meshflow_native_mesh_t;

/* Why a call failed. The messages are the host's: a run refused by a host and natively
 * read the same. */
typedef uint8_t meshflow_native_error_kind_t;
#define MESHFLOW_NATIVE_ERROR_FILE 1            /* a mesh file could not be read or written */
#define MESHFLOW_NATIVE_ERROR_INVALID_MESH 2    /* arrays that are no mesh */
#define MESHFLOW_NATIVE_ERROR_UNKNOWN_SERVICE 3 /* the plugin describes no such service */
#define MESHFLOW_NATIVE_ERROR_PARAMS 4          /* parameters the host refuses */
#define MESHFLOW_NATIVE_ERROR_FAILED 5          /* the service returned an error */
#define MESHFLOW_NATIVE_ERROR_BAD_RESULT 6      /* a check's value unlike its description */
#define MESHFLOW_NATIVE_ERROR_CRASHED 7         /* what a host would trap on */
#define MESHFLOW_NATIVE_ERROR_ARGUMENT 8        /* a wrong argument to this API */
#define MESHFLOW_NATIVE_ERROR_INTERNAL 9        /* a bug of this library */

typedef struct meshflow_native_error_t {
    meshflow_native_error_kind_t kind;
    plugin_string_t message;
} meshflow_native_error_t;
void meshflow_native_error_free(meshflow_native_error_t *err);

/* Loads OBJ, PLY, OFF or STL (the format from the extension) as a host does. */
bool meshflow_native_load(const char *path, size_t len, meshflow_native_mesh_t **out,
                          meshflow_native_error_t *err);
/* x y z per vertex (finite), a b c per triangle (in range). */
bool meshflow_native_mesh_new(const float *xyz, size_t xyz_len, const uint32_t *abc,
                              size_t abc_len, meshflow_native_mesh_t **out,
                              meshflow_native_error_t *err);
/* Writes binary PLY, OBJ or OFF (from the extension) as a host does. */
bool meshflow_native_save(const meshflow_native_mesh_t *mesh, const char *path, size_t len,
                          meshflow_native_error_t *err);
meshflow_native_mesh_t *meshflow_native_mesh_clone(const meshflow_native_mesh_t *mesh);
void meshflow_native_mesh_free(meshflow_native_mesh_t *mesh);
uint32_t meshflow_native_mesh_vertex_count(const meshflow_native_mesh_t *mesh);
uint32_t meshflow_native_mesh_triangle_count(const meshflow_native_mesh_t *mesh);
/* Borrowed for as long as the mesh lives. */
const float *meshflow_native_mesh_positions(const meshflow_native_mesh_t *mesh, size_t *len);
const uint32_t *meshflow_native_mesh_triangles(const meshflow_native_mesh_t *mesh, size_t *len);
/* The canonical content hash as `meshflow hash` prints it: 64 hex digits and a NUL. */
void meshflow_native_mesh_hash(const meshflow_native_mesh_t *mesh, char out[65]);

/* What a run gave. */
typedef struct meshflow_native_outcome_t {
    meshflow_native_mesh_t *mesh; /* compacted as a host compacts it (a check's: its input) */
    plugin_string_t report;       /* a filter's report */
    meshflow_geometry_types_option_value_t value; /* a check's value */
    uint64_t edits;               /* edited elements, as `meshflow apply` counts them */
    plugin_list_string_t ops;     /* the recorded operations' kinds, in order */
} meshflow_native_outcome_t;
void meshflow_native_outcome_free(meshflow_native_outcome_t *outcome);

typedef void (*meshflow_native_describe_fn)(
    exports_meshflow_geometry_service_list_service_info_t *ret);
typedef bool (*meshflow_native_run_fn)(plugin_string_t *name,
                                       exports_meshflow_geometry_service_borrow_mesh_t target,
                                       exports_meshflow_geometry_service_list_param_t *params,
                                       exports_meshflow_geometry_service_outcome_t *ret,
                                       plugin_string_t *err);

/* Runs `service` on a copy of `mesh` through the plugin's exports (pass
 * exports_meshflow_geometry_service_describe and _run): parameters resolved by the host's
 * rules (defaults filled in, types and ranges checked; `params` is borrowed), a check on a
 * read-only mesh, a check's value checked against its type, the result compacted. */
bool meshflow_native_run(meshflow_native_describe_fn describe, meshflow_native_run_fn run,
                         const char *service, size_t service_len,
                         const meshflow_native_mesh_t *mesh,
                         const meshflow_geometry_types_param_t *params, size_t params_len,
                         meshflow_native_outcome_t *out, meshflow_native_error_t *err);

#ifdef __cplusplus
}
#endif

#endif
