// meshflow.hpp: write meshflow plugins in C++ (C++23). The C++ twin of the Rust SDK's
// `Mesh` and `export_plugin!`, over the C bindings that wit-bindgen generates from meshflow's
// WIT (../generated/plugin.h):
//
//   - `meshflow::Mesh`: the host's mesh, read as spans-ready vectors of floats and ids,
//     edited in bulk; every edit is recorded by the host, a refused one comes back as an
//     error value; its attributes (colours, quality, normals, texture coordinates, other
//     numbers by name) read and written whole;
//   - `meshflow::Service`, `meshflow::Param`: services and typed parameters described in
//     code; `meshflow::Params` reads them;
//   - `MESHFLOW_EXPORT_PLUGIN(services)`: exports a `std::vector<Service> services()`.
//
// Errors are return values (`meshflow::Result<T>` = `std::expected<T, Error>`), so
// plugins build with -fno-exceptions: `MESHFLOW_TRY(expr)` returns a failed result from the
// enclosing service and otherwise gives its value; `meshflow::fail("{} holes", n)` formats. Link ../generated/plugin.c and
// ../generated/plugin_component_type.o, build for wasm32-wasi (preview 1) as a reactor, then
// `meshflow plugin componentize CORE.wasm -o PLUGIN.wasm`.
//
// Tests: built for the host's CPU with -DMESHFLOW_NATIVE and linked against
// libmeshflow_native.so instead of plugin.c, the same services run in process on the host's
// own recording store (every edit checked as a host checks it), through
// `meshflow::native::load(path)` and `meshflow::native::run(service, mesh, params)`.
#pragma once

extern "C" {
#include "plugin.h"
}
#ifdef MESHFLOW_NATIVE
#include "meshflow_native.h"
#endif

#include <array>
#include <concepts>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <format>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace meshflow {

// ---- errors ---------------------------------------------------------------------------------

// What kind of failure an Error is: an edit the host refused (the WIT's edit-error-kind,
// in its order), a service's own failure, or (native runs only) what a host refuses around
// a run.
enum class ErrorKind : uint8_t {
    InvalidVertex,
    InvalidTriangle,
    InvalidEdge,
    RepeatedVertex,
    InvalidArgument,
    NotApplicable,
    ReadOnly,
    Failed,          // meshflow::fail(), or a service's failure
    File,            // native: a mesh file could not be read or written
    InvalidMesh,     // native: arrays that are no mesh
    UnknownService,  // native: the plugin describes no such service
    Params,          // native: parameters the host refuses
    BadResult,       // native: a check's value unlike its declared type
    Crashed,         // native: what a host would trap on
    Argument,        // native: a wrong argument to the native API
    Internal,        // native: a bug of the native library
};

// How the host names a kind: "repeated vertex", "read-only mesh", ….
constexpr std::string_view to_string(ErrorKind kind) {
    constexpr std::string_view names[] = {
        "invalid vertex", "invalid triangle", "invalid edge",    "repeated vertex",
        "invalid argument", "not applicable", "read-only mesh",  "failed",
        "file",           "invalid mesh",     "unknown service", "parameters",
        "bad result",     "crashed",          "argument",        "internal"};
    return size_t(kind) < std::size(names) ? names[size_t(kind)] : "refused";
}

// Why a service failed: a message the host shows to the user, and its kind. A refused edit
// keeps the host's kind, also through MESHFLOW_TRY.
struct Error {
    std::string message;
    ErrorKind kind = ErrorKind::Failed;
};

template <class T = void>
using Result = std::expected<T, Error>;

// A failed result with this message: `return meshflow::fail("no triangles");`.
inline std::unexpected<Error> fail(std::string message) {
    return std::unexpected(Error{std::move(message)});
}
// A failed result with a std::format message: `return meshflow::fail("{} > {}", a, b);`.
template <class... Args>
    requires(sizeof...(Args) > 0)
std::unexpected<Error> fail(std::format_string<Args...> format, Args&&... args) {
    return std::unexpected(Error{std::format(format, std::forward<Args>(args)...)});
}

// What the triangles of a removed triangle read, in all three corners.
inline constexpr uint32_t REMOVED = 0xFFFFFFFFu;

namespace detail {

inline std::string to_string(const plugin_string_t& s) {
    return std::string(reinterpret_cast<const char*>(s.ptr), s.len);
}

// A string the bindings free with their own `free`.
inline plugin_string_t owned(std::string_view s) {
    plugin_string_t out{nullptr, s.size()};
    if (!s.empty()) {
        out.ptr = static_cast<uint8_t*>(std::malloc(s.size()));
        std::memcpy(out.ptr, s.data(), s.size());
    }
    return out;
}

inline Error edit_error(meshflow_geometry_mesh_edit_error_t& e) {
    ErrorKind kind = e.kind <= uint8_t(ErrorKind::ReadOnly) ? ErrorKind(e.kind) : ErrorKind::Failed;
    Error error{"edit refused (" + std::string(meshflow::to_string(kind)) +
                    "): " + to_string(e.message),
                kind};
    meshflow_geometry_mesh_edit_error_free(&e);
    return error;
}

#ifdef MESHFLOW_NATIVE
// The kind of the last failure of a service run natively on this thread: the C ABI carries
// only its message, as the WIT does.
inline ErrorKind& native_failure_kind() {
    thread_local ErrorKind kind = ErrorKind::Failed;
    return kind;
}
#endif

// MESHFLOW_TRY's value: the result's, or nothing for Result<>.
template <class T>
T take_value(std::expected<T, Error>&& r) {
    return std::move(*r);
}
inline void take_value(std::expected<void, Error>&&) {}

// A plugin bug (a parameter it did not declare): no exceptions to throw, so the run stops
// with the message on stderr, which the host shows.
[[noreturn]] inline void bug(const std::string& message) {
    std::fprintf(stderr, "meshflow plugin bug: %s\n", message.c_str());
    std::fflush(stderr);
    std::abort();
}

template <class List, class T>
List list_of(std::span<const T> items) {
    return List{const_cast<T*>(items.data()), items.size()};
}

// A string argument, borrowed for the call (an import does not free its arguments).
inline plugin_string_t borrowed(std::string_view s) {
    return plugin_string_t{reinterpret_cast<uint8_t*>(const_cast<char*>(s.data())), s.size()};
}

template <class T>
std::vector<T> copy_list(const T* ptr, size_t len) {
    return len ? std::vector<T>(ptr, ptr + len) : std::vector<T>{};
}

// The bindings' attribute values as vectors (copied; the caller frees the C values).
inline std::variant<std::vector<uint8_t>, std::vector<int32_t>, std::vector<uint32_t>,
                    std::vector<float>, std::vector<double>>
values_from_c(const meshflow_geometry_mesh_attribute_values_t& v) {
    switch (v.tag) {
        case MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_U8: return copy_list(v.val.u8.ptr, v.val.u8.len);
        case MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_S32: return copy_list(v.val.s32.ptr, v.val.s32.len);
        case MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_U32: return copy_list(v.val.u32.ptr, v.val.u32.len);
        case MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_F32: return copy_list(v.val.f32.ptr, v.val.f32.len);
        default: return copy_list(v.val.f64.ptr, v.val.f64.len);
    }
}

}  // namespace detail

// ---- values and parameters ------------------------------------------------------------------

enum class ValueType : uint8_t { Boolean, Integer, Real, Text };

// A parameter value or a check's result.
using Value = std::variant<bool, int64_t, double, std::string>;

// The parameters of one run; the host has checked them against the description and filled
// in defaults, so a lookup fails only for a name the service did not declare.
class Params {
public:
    explicit Params(std::vector<std::pair<std::string, Value>> values) : values_(std::move(values)) {}

    // Direct getters: the host has checked every declared parameter, so these return the
    // value itself. Asking for a name the service did not declare (or with another type)
    // is a bug in the plugin: the run stops with a message.
    int64_t get_integer(std::string_view name) const { return must(integer(name)); }
    bool get_boolean(std::string_view name) const { return must(boolean(name)); }
    std::string get_text(std::string_view name) const { return must(text(name)); }
    double get_real(std::string_view name) const { return must(real(name)); }

    // The same as results, for code that would rather handle a wrong name itself.
    Result<int64_t> integer(std::string_view name) const { return get<int64_t>(name, "an integer"); }
    Result<bool> boolean(std::string_view name) const { return get<bool>(name, "a boolean"); }
    Result<std::string> text(std::string_view name) const { return get<std::string>(name, "a text"); }
    // A real parameter; an integer is widened.
    Result<double> real(std::string_view name) const {
        auto v = find(name);
        if (!v) return fail("parameter `" + std::string(name) + "` was not given");
        if (auto* i = std::get_if<int64_t>(*v)) return double(*i);
        if (auto* d = std::get_if<double>(*v)) return *d;
        return fail("parameter `" + std::string(name) + "` should be a real");
    }

private:
    template <class T>
    static T must(Result<T> r) {
        if (!r) detail::bug(r.error().message);
        return std::move(*r);
    }
    std::optional<const Value*> find(std::string_view name) const {
        for (auto& [n, v] : values_)
            if (n == name) return &v;
        return std::nullopt;
    }
    template <class T>
    Result<T> get(std::string_view name, const char* what) const {
        auto v = find(name);
        if (!v) return fail("parameter `" + std::string(name) + "` was not given");
        if (auto* t = std::get_if<T>(*v)) return *t;
        return fail("parameter `" + std::string(name) + "` should be " + what);
    }
    std::vector<std::pair<std::string, Value>> values_;
};

// A parameter declaration: name, type, default, and optionally range, choices and doc.
struct Param {
    std::string name;
    Value default_value;
    std::optional<double> min, max;
    std::vector<std::string> choices;
    std::string doc_text;

    Param(std::string name, Value value) : name(std::move(name)), default_value(std::move(value)) {}

    static Param integer(std::string name, int64_t value) { return {std::move(name), value}; }
    static Param real(std::string name, double value) { return {std::move(name), value}; }
    static Param boolean(std::string name, bool value) { return {std::move(name), value}; }
    // A text parameter that must be one of `choices`.
    static Param choice(std::string name, std::string value, std::vector<std::string> choices) {
        Param p(std::move(name), std::move(value));
        p.choices = std::move(choices);
        return p;
    }
    // Inclusive bounds; the host refuses values outside them. Chains on a temporary
    // (`Param::real("x", 1).range(0, 2).doc("…")`) and on a named one (`p.range(0, 2);`).
    Param& range(double lo, double hi) & {
        min = lo;
        max = hi;
        return *this;
    }
    Param range(double lo, double hi) && { return std::move(range(lo, hi)); }
    Param& doc(std::string text) & {
        doc_text = std::move(text);
        return *this;
    }
    Param doc(std::string text) && { return std::move(doc(std::move(text))); }
};

// ---- the mesh ---------------------------------------------------------------------------------

// An array the host handed over (positions, triangles, ids), owned without a second copy:
// the bindings allocate it, this frees it. Reads like a span (size(), [], begin/end), passes
// where a std::span<const T> is taken, and is writable in place; `to_vector()` copies.
template <class T>
class Array {
public:
    Array() = default;
    Array(T* data, size_t size) : data_(data), size_(size) {}

    size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    T* data() { return data_.get(); }
    const T* data() const { return data_.get(); }
    T& operator[](size_t i) { return data_.get()[i]; }
    const T& operator[](size_t i) const { return data_.get()[i]; }
    T* begin() { return data(); }
    T* end() { return data() + size_; }
    const T* begin() const { return data(); }
    const T* end() const { return data() + size_; }

    operator std::span<const T>() const { return {data(), size_}; }
    operator std::span<T>() { return {data(), size_}; }
    std::span<const T> span() const { return *this; }
    std::vector<T> to_vector() const { return {begin(), end()}; }

private:
    struct Free {
        void operator()(T* p) const { std::free(p); }
    };
    std::unique_ptr<T, Free> data_;
    size_t size_ = 0;
};

// ---- attributes: what a mesh carries beyond positions and triangles --------------------------

// The elements an attribute has one value for (the WIT's attribute-domain, in its order).
enum class Domain : uint8_t { Vertex, Face, Corner };
// The type an attribute keeps its numbers in (the WIT's number-type, in its order).
enum class NumberType : uint8_t { U8, S32, U32, F32, F64 };

// The well-known names: colour (4 × u8, RGBA), normal (3 × f32, recomputed by the host where
// the geometry changed unless the run set it), quality (1 × f32), texture coordinate
// (2 × f32, per vertex or corner), material (per face, 1 × u32).
inline constexpr std::string_view COLOR = "color";
inline constexpr std::string_view NORMAL = "normal";
inline constexpr std::string_view QUALITY = "quality";
inline constexpr std::string_view TEXCOORD = "texcoord";
inline constexpr std::string_view MATERIAL = "material";

// One attribute as Mesh::attributes() lists it.
struct AttributeInfo {
    Domain domain;
    std::string name;
    uint8_t components;  // numbers per element, 1 to 4
    NumberType type;
};

// An attribute's numbers, `components` per element, in its own type; the variant's index is
// its NumberType.
using AttributeValues = std::variant<std::vector<uint8_t>, std::vector<int32_t>,
                                     std::vector<uint32_t>, std::vector<float>, std::vector<double>>;

// An edge-connected component of the live triangles, as Mesh::components lists it:
// `first_triangle` (its smallest triangle id, what remove_component takes) and `triangles`.
using Component = meshflow_geometry_mesh_component_t;

// The half-edge from corner `k` (0, 1, 2) of triangle `t` to corner `(k + 1) % 3`: the edge
// ids that split_edge, swap_edge, collapse_edge and extend_edge take.
constexpr uint32_t half_edge(uint32_t t, uint32_t k) { return 3 * t + k; }

// A borrowed handle to the mesh a service runs on: every call of the WIT `mesh` resource.
// Read arrays once, compute, write edits back in bulk: each call crosses the sandbox boundary
// (~100 ns) and each element is copied. Every edit is recorded by the host; a refused one
// comes back as an error value, the mesh unchanged.
class Mesh {
public:
    explicit Mesh(meshflow_geometry_mesh_borrow_mesh_t raw) : raw_(raw) {}

    // ---- reading

    // Vertex and triangle ids in use (removed ones included), and live counts.
    uint32_t vertex_slots() const { return meshflow_geometry_mesh_method_mesh_vertex_slots(raw_); }
    uint32_t triangle_slots() const { return meshflow_geometry_mesh_method_mesh_triangle_slots(raw_); }
    uint32_t vertex_count() const { return meshflow_geometry_mesh_method_mesh_vertex_count(raw_); }
    uint32_t triangle_count() const { return meshflow_geometry_mesh_method_mesh_triangle_count(raw_); }

    // x y z per vertex slot (removed vertices keep their last position).
    Array<float> positions() const {
        plugin_list_f32_t list;
        meshflow_geometry_mesh_method_mesh_positions(raw_, &list);
        return {list.ptr, list.len};
    }
    // a b c per triangle slot; a removed triangle reads REMOVED three times.
    Array<uint32_t> triangles() const {
        plugin_list_u32_t list;
        meshflow_geometry_mesh_method_mesh_triangles(raw_, &list);
        return {list.ptr, list.len};
    }
    // Ids of the vertices removed during this run, ascending.
    Array<uint32_t> removed_vertices() const {
        plugin_list_u32_t list;
        meshflow_geometry_mesh_method_mesh_removed_vertices(raw_, &list);
        return {list.ptr, list.len};
    }
    // ---- derived connectivity (the host derives it once per mesh version; see the WIT)

    // Per half-edge: the other half-edge on its edge when the edge has exactly two, else
    // REMOVED (u32 max).
    Array<uint32_t> half_edge_opposites() const {
        plugin_list_u32_t list;
        meshflow_geometry_mesh_method_mesh_half_edge_opposites(raw_, &list);
        return {list.ptr, list.len};
    }
    // Per half-edge: 0 not a proper triangle, 1 boundary, 2 interior, 3 interior with both
    // half-edges running the same way, 4 non-manifold.
    Array<uint8_t> half_edge_kinds() const {
        plugin_list_u8_t list;
        meshflow_geometry_mesh_method_mesh_half_edge_kinds(raw_, &list);
        return {list.ptr, list.len};
    }
    // Every edge once, by its smallest half-edge id, in ascending (smaller, larger) vertex order.
    Array<uint32_t> edges() const {
        plugin_list_u32_t list;
        meshflow_geometry_mesh_method_mesh_edges(raw_, &list);
        return {list.ptr, list.len};
    }
    // The edge-connected components of the live triangles, ascending by first triangle,
    // derived by the host: a service that only chooses whole pieces need not read the mesh.
    Array<Component> components() const {
        meshflow_geometry_mesh_list_component_t list;
        meshflow_geometry_mesh_method_mesh_components(raw_, &list);
        return {list.ptr, list.len};
    }

    // One vertex's x y z; an error for a dead or unknown id.
    Result<std::array<float, 3>> position(uint32_t vertex) const {
        plugin_tuple3_f32_f32_f32_t p;
        if (!meshflow_geometry_mesh_method_mesh_position(raw_, vertex, &p, &error_)) return failed();
        return std::array<float, 3>{p.f0, p.f1, p.f2};
    }
    // One triangle's corners; an error for a dead or unknown id.
    Result<std::array<uint32_t, 3>> triangle(uint32_t triangle) const {
        plugin_tuple3_u32_u32_u32_t t;
        if (!meshflow_geometry_mesh_method_mesh_triangle(raw_, triangle, &t, &error_)) return failed();
        return std::array<uint32_t, 3>{t.f0, t.f1, t.f2};
    }
    bool is_vertex_live(uint32_t vertex) const {
        return meshflow_geometry_mesh_method_mesh_is_vertex_live(raw_, vertex);
    }
    bool is_triangle_live(uint32_t triangle) const {
        return meshflow_geometry_mesh_method_mesh_is_triangle_live(raw_, triangle);
    }

    // ---- vertices

    // Appends a vertex; its id.
    Result<uint32_t> add_vertex(float x, float y, float z) const {
        uint32_t v;
        return id(meshflow_geometry_mesh_method_mesh_add_vertex(raw_, x, y, z, &v, &error_), v);
    }
    // Appends xyz.size() / 3 vertices; the first new id.
    Result<uint32_t> add_vertices(std::span<const float> xyz) const {
        auto list = detail::list_of<plugin_list_f32_t>(xyz);
        uint32_t first;
        return id(meshflow_geometry_mesh_method_mesh_add_vertices(raw_, &list, &first, &error_), first);
    }
    Result<> move_vertex(uint32_t vertex, float x, float y, float z) const {
        return unit(meshflow_geometry_mesh_method_mesh_move_vertex(raw_, vertex, x, y, z, &error_));
    }
    // Moves ids[i] to xyz[3i .. 3i + 3].
    Result<> move_vertices(std::span<const uint32_t> ids, std::span<const float> xyz) const {
        auto i = detail::list_of<plugin_list_u32_t>(ids);
        auto p = detail::list_of<plugin_list_f32_t>(xyz);
        return unit(meshflow_geometry_mesh_method_mesh_move_vertices(raw_, &i, &p, &error_));
    }
    // Moves every vertex: 3 values per vertex slot (removed slots ignored). One edit.
    Result<> set_positions(std::span<const float> xyz) const {
        auto list = detail::list_of<plugin_list_f32_t>(xyz);
        return unit(meshflow_geometry_mesh_method_mesh_set_positions(raw_, &list, &error_));
    }
    // Removes a vertex and every triangle that uses it.
    Result<> remove_vertex(uint32_t vertex) const {
        return unit(meshflow_geometry_mesh_method_mesh_remove_vertex(raw_, vertex, &error_));
    }
    Result<> remove_vertices(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_remove_vertices(raw_, &list, &error_));
    }

    // ---- triangles

    // Appends a triangle of live, distinct corners; its id.
    Result<uint32_t> add_triangle(uint32_t a, uint32_t b, uint32_t c) const {
        uint32_t t;
        return id(meshflow_geometry_mesh_method_mesh_add_triangle(raw_, a, b, c, &t, &error_), t);
    }
    // Appends abc.size() / 3 triangles of live, distinct corners; the first new id.
    Result<uint32_t> add_triangles(std::span<const uint32_t> abc) const {
        auto list = detail::list_of<plugin_list_u32_t>(abc);
        uint32_t first;
        return id(meshflow_geometry_mesh_method_mesh_add_triangles(raw_, &list, &first, &error_), first);
    }
    // Removes triangles; their vertices stay, even if no triangle uses them any more.
    Result<> remove_triangle(uint32_t triangle) const {
        return unit(meshflow_geometry_mesh_method_mesh_remove_triangle(raw_, triangle, &error_));
    }
    Result<> remove_triangles(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_remove_triangles(raw_, &list, &error_));
    }
    // Reverses orientation (swaps corners 1 and 2).
    Result<> flip_triangle(uint32_t triangle) const {
        return unit(meshflow_geometry_mesh_method_mesh_flip_triangle(raw_, triangle, &error_));
    }
    Result<> flip_triangles(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_flip_triangles(raw_, &list, &error_));
    }
    // Splits a triangle into three around a new vertex at its centroid; the new vertex. The
    // triangle keeps its id as the piece on edge 0; the two others are appended.
    Result<uint32_t> split_triangle(uint32_t triangle) const {
        uint32_t v;
        return id(meshflow_geometry_mesh_method_mesh_split_triangle(raw_, triangle, &v, &error_), v);
    }
    // As split_triangle, with the new vertex at (x, y, z).
    Result<uint32_t> split_triangle_at(uint32_t triangle, float x, float y, float z) const {
        uint32_t v;
        return id(meshflow_geometry_mesh_method_mesh_split_triangle_at(raw_, triangle, x, y, z, &v, &error_),
                  v);
    }

    // ---- edges: half-edge ids, see half_edge(t, k)

    // Adds the triangle on the far side of half-edge a -> b with apex `vertex`, oriented
    // b a vertex; its id.
    Result<uint32_t> extend_edge(uint32_t edge, uint32_t vertex) const {
        uint32_t t;
        return id(meshflow_geometry_mesh_method_mesh_extend_edge(raw_, edge, vertex, &t, &error_), t);
    }
    // Splits the edge at its midpoint, and every triangle that has it; the new vertex.
    Result<uint32_t> split_edge(uint32_t edge) const {
        uint32_t v;
        return id(meshflow_geometry_mesh_method_mesh_split_edge(raw_, edge, &v, &error_), v);
    }
    // As split_edge, with the new vertex at (x, y, z).
    Result<uint32_t> split_edge_at(uint32_t edge, float x, float y, float z) const {
        uint32_t v;
        return id(meshflow_geometry_mesh_method_mesh_split_edge_at(raw_, edge, x, y, z, &v, &error_), v);
    }
    // Replaces the two triangles on a manifold interior edge by the two on the other diagonal.
    Result<> swap_edge(uint32_t edge) const {
        return unit(meshflow_geometry_mesh_method_mesh_swap_edge(raw_, edge, &error_));
    }
    // Merges the edge's end vertex into its start vertex, which keeps its position; triangles
    // that become degenerate are removed.
    Result<> collapse_edge(uint32_t edge) const {
        return unit(meshflow_geometry_mesh_method_mesh_collapse_edge(raw_, edge, &error_));
    }

    // ---- whole components, the whole mesh

    // Removes the edge-connected component containing `triangle`, and the vertices no
    // triangle uses any more.
    Result<> remove_component(uint32_t triangle) const {
        return unit(meshflow_geometry_mesh_method_mesh_remove_component(raw_, triangle, &error_));
    }
    // Applies a row-major 3x4 affine map to every vertex of the component of `triangle`.
    Result<> transform_component(uint32_t triangle, std::span<const float, 12> matrix) const {
        auto list = detail::list_of<plugin_list_f32_t>(std::span<const float>(matrix));
        return unit(meshflow_geometry_mesh_method_mesh_transform_component(raw_, triangle, &list, &error_));
    }
    // Applies a row-major 3x4 affine map ([r00 r01 r02 t0 r10 … t2]) to every vertex.
    Result<> transform(std::span<const float, 12> matrix) const {
        auto list = detail::list_of<plugin_list_f32_t>(std::span<const float>(matrix));
        return unit(meshflow_geometry_mesh_method_mesh_transform(raw_, &list, &error_));
    }
    // Removes every vertex and triangle.
    Result<> clear() const { return unit(meshflow_geometry_mesh_method_mesh_clear(raw_, &error_)); }

    // ---- attributes, whole arrays (one call and one copy each). The host keeps them through
    // every edit (splits interpolate, collapses keep the survivor's); vertices from
    // add_vertices take the defaults (opaque white, else zero) unless the run sets them, and
    // the step's report says so.

    // Every attribute of the mesh, by domain, then name.
    std::vector<AttributeInfo> attributes() const {
        meshflow_geometry_mesh_list_attribute_info_t list;
        meshflow_geometry_mesh_method_mesh_attributes(raw_, &list);
        std::vector<AttributeInfo> out;
        out.reserve(list.len);
        for (size_t i = 0; i < list.len; ++i) {
            auto& a = list.ptr[i];
            out.push_back({Domain(a.domain), detail::to_string(a.name), a.components,
                           NumberType(a.number_type)});
        }
        meshflow_geometry_mesh_list_attribute_info_free(&list);
        return out;
    }
    // An attribute's numbers for every slot of its domain (removed elements keep their last
    // values); nullopt when the mesh does not carry it.
    std::optional<AttributeValues> read_attribute(Domain domain, std::string_view name) const {
        meshflow_geometry_mesh_attribute_values_t v;
        auto n = detail::borrowed(name);
        if (!meshflow_geometry_mesh_method_mesh_read_attribute(raw_, uint8_t(domain), &n, &v, &error_)) {
            meshflow_geometry_mesh_edit_error_free(&error_);
            return std::nullopt;
        }
        auto out = detail::values_from_c(v);
        meshflow_geometry_mesh_attribute_values_free(&v);
        return out;
    }
    // Sets an attribute at `ids` (`components` numbers each, in order), or at every slot of
    // its domain when `ids` is nullopt; an attribute the mesh does not carry yet is made, the
    // other elements at the default. The type and `components` must match the attribute's
    // (and the well-known names' shapes). A check gets a read-only error.
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids,
                           std::span<const uint8_t> values) const {
        return set(domain, name, components, ids, MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_U8, values);
    }
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids,
                           std::span<const int32_t> values) const {
        return set(domain, name, components, ids, MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_S32, values);
    }
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids,
                           std::span<const uint32_t> values) const {
        return set(domain, name, components, ids, MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_U32, values);
    }
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids,
                           std::span<const float> values) const {
        return set(domain, name, components, ids, MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_F32, values);
    }
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids,
                           std::span<const double> values) const {
        return set(domain, name, components, ids, MESHFLOW_GEOMETRY_MESH_ATTRIBUTE_VALUES_F64, values);
    }
    // The values read_attribute gives (a template only so that a vector picks its span).
    template <class V>
        requires std::same_as<V, AttributeValues>
    Result<> set_attribute(Domain domain, std::string_view name, uint8_t components,
                           std::optional<std::span<const uint32_t>> ids, const V& values) const {
        return std::visit(
            [&](const auto& v) {
                using T = typename std::decay_t<decltype(v)>::value_type;
                return set_attribute(domain, name, components, ids, std::span<const T>(v));
            },
            values);
    }
    // Drops an attribute; an error when the mesh does not carry it.
    Result<> remove_attribute(Domain domain, std::string_view name) const {
        auto n = detail::borrowed(name);
        return unit(meshflow_geometry_mesh_method_mesh_remove_attribute(raw_, uint8_t(domain), &n, &error_));
    }

    // RGBA per vertex slot, if the mesh has colours.
    std::optional<std::vector<std::array<uint8_t, 4>>> vertex_colors() const {
        return grouped<uint8_t, 4>(Domain::Vertex, COLOR);
    }
    // Sets colours at `ids` (every vertex slot when nullopt).
    Result<> set_vertex_colors(std::optional<std::span<const uint32_t>> ids,
                               std::span<const std::array<uint8_t, 4>> rgba) const {
        return set_attribute(Domain::Vertex, COLOR, 4, ids,
                             std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(rgba.data()), 4 * rgba.size()));
    }
    // Quality per vertex slot, if the mesh has it.
    std::optional<std::vector<float>> quality() const {
        auto v = read_attribute(Domain::Vertex, QUALITY);
        if (!v || v->index() != size_t(NumberType::F32)) return std::nullopt;
        return std::get<std::vector<float>>(std::move(*v));
    }
    // Sets quality at `ids` (every vertex slot when nullopt); values must be finite.
    Result<> set_quality(std::optional<std::span<const uint32_t>> ids, std::span<const float> q) const {
        return set_attribute(Domain::Vertex, QUALITY, 1, ids, q);
    }
    // The normal per vertex slot, if the mesh carries normals.
    std::optional<std::vector<std::array<float, 3>>> vertex_normals() const {
        return grouped<float, 3>(Domain::Vertex, NORMAL);
    }
    // Sets normals at `ids`; the host then keeps them rather than recomputing them.
    Result<> set_vertex_normals(std::optional<std::span<const uint32_t>> ids,
                                std::span<const std::array<float, 3>> normals) const {
        return set_attribute(Domain::Vertex, NORMAL, 3, ids,
                             std::span<const float>(reinterpret_cast<const float*>(normals.data()), 3 * normals.size()));
    }
    // u v per vertex slot, if the mesh has per-vertex texture coordinates.
    std::optional<std::vector<std::array<float, 2>>> vertex_texcoords() const {
        return grouped<float, 2>(Domain::Vertex, TEXCOORD);
    }
    // u v per corner (3t + k), if the mesh has per-corner texture coordinates.
    std::optional<std::vector<std::array<float, 2>>> corner_texcoords() const {
        return grouped<float, 2>(Domain::Corner, TEXCOORD);
    }

private:
    template <class T>
    Result<> set(Domain domain, std::string_view name, uint8_t components,
                 std::optional<std::span<const uint32_t>> ids, uint8_t tag,
                 std::span<const T> values) const {
        auto n = detail::borrowed(name);
        plugin_list_u32_t id_list{};
        if (ids) id_list = detail::list_of<plugin_list_u32_t>(*ids);
        meshflow_geometry_mesh_attribute_values_t v{};
        v.tag = tag;
        // Every list of the union is {ptr, len}: write it through the u8 member's layout.
        v.val.u8 = plugin_list_u8_t{reinterpret_cast<uint8_t*>(const_cast<T*>(values.data())),
                                    values.size()};
        return unit(meshflow_geometry_mesh_method_mesh_set_attribute(
            raw_, uint8_t(domain), &n, components, ids ? &id_list : nullptr, &v, &error_));
    }
    // An attribute of N numbers of T per element, grouped; nullopt if absent or of another shape.
    template <class T, size_t N>
    std::optional<std::vector<std::array<T, N>>> grouped(Domain domain, std::string_view name) const {
        auto v = read_attribute(domain, name);
        if (!v) return std::nullopt;
        auto* flat = std::get_if<std::vector<T>>(&*v);
        if (!flat || flat->size() % N != 0) return std::nullopt;
        std::vector<std::array<T, N>> out(flat->size() / N);
        if (!flat->empty()) std::memcpy(out.data(), flat->data(), flat->size() * sizeof(T));
        return out;
    }

    std::unexpected<Error> failed() const { return std::unexpected(detail::edit_error(error_)); }
    Result<> unit(bool ok) const {
        if (ok) return {};
        return failed();
    }
    Result<uint32_t> id(bool ok, uint32_t value) const {
        if (ok) return value;
        return failed();
    }

    meshflow_geometry_mesh_borrow_mesh_t raw_;
    mutable meshflow_geometry_mesh_edit_error_t error_{};
};

// ---- services ---------------------------------------------------------------------------------

// A filter edits the mesh and returns a short report of what it did. Any callable: a
// function, or a lambda that captures.
using FilterFn = std::function<Result<std::string>(const Mesh&, const Params&)>;
// A check reads the mesh (the host refuses edits) and returns a value.
using CheckFn = std::function<Result<Value>(const Mesh&, const Params&)>;

// How many rings of the mesh around a vertex a local filter's result there depends on.
using ReachFn = std::function<uint32_t(const Params&)>;
// Above how many triangles a filter runs block by block; nullopt or 0: whole.
using BlocksFn = std::function<std::optional<uint32_t>(const Params&)>;

// One service of a plugin: its description and the function that runs it.
struct Service {
    std::string name, doc;
    std::variant<FilterFn, CheckFn> run;
    ValueType result = ValueType::Integer;  // checks only
    std::vector<Param> params;
    ReachFn reach;             // local filters only
    BlocksFn block_triangles;  // filters run block by block only

    static Service filter(std::string name, std::string doc, FilterFn f) {
        return {std::move(name), std::move(doc), std::move(f), ValueType::Integer, {}, {}, {}};
    }
    static Service check(std::string name, std::string doc, ValueType result, CheckFn f) {
        return {std::move(name), std::move(doc), std::move(f), result, {}, {}, {}};
    }
    // Declares a parameter; chains on a temporary and on a named service.
    Service& param(Param p) & {
        params.push_back(std::move(p));
        return *this;
    }
    Service param(Param p) && { return std::move(param(std::move(p))); }
    // Declares the filter local (WIT `locality`), as the Rust SDK's `Service::local`: it
    // only moves vertices, and a vertex's new position depends only on the mesh within
    // `reach(params)` rings of it, neighbours taken in ascending id order. A host may then
    // run it on partitions of a mesh too large for one sandbox, and checks that the result
    // is the same bit for bit.
    Service& local(ReachFn f) & {
        reach = std::move(f);
        return *this;
    }
    Service local(ReachFn f) && { return std::move(local(std::move(f))); }
    // Declares that on a mesh of more than `f(params)` triangles (when it gives a count, not
    // 0) the filter's result is, by definition, its result on each block of about that many
    // triangles run as a mesh of its own, the vertices blocks share kept where they are (WIT
    // `blocks`), as the Rust SDK's `Service::blocks`. Every host cuts the same blocks, so
    // results agree across hosts, but not with a whole-mesh run. A block's border is its
    // boundary: a filter that may move or remove boundary vertices with these parameters
    // must give nullopt. A host refuses blocks of fewer than 1000 triangles, and edits it
    // cannot rename into the mesh (set_positions, transform, clear, component, attribute).
    Service& blocks(BlocksFn f) & {
        block_triangles = std::move(f);
        return *this;
    }
    Service blocks(BlocksFn f) && { return std::move(blocks(std::move(f))); }
};

namespace detail {

using types_value_t = meshflow_geometry_types_value_t;

inline ValueType type_of(const Value& v) { return ValueType(v.index()); }

inline types_value_t to_c(const Value& v) {
    types_value_t out{};
    out.tag = uint8_t(v.index());
    switch (v.index()) {
        case 0: out.val.boolean = std::get<bool>(v); break;
        case 1: out.val.integer = std::get<int64_t>(v); break;
        case 2: out.val.real = std::get<double>(v); break;
        default: out.val.text = owned(std::get<std::string>(v)); break;
    }
    return out;
}

inline Value from_c(const types_value_t& v) {
    switch (v.tag) {
        case MESHFLOW_GEOMETRY_TYPES_VALUE_BOOLEAN: return v.val.boolean;
        case MESHFLOW_GEOMETRY_TYPES_VALUE_INTEGER: return v.val.integer;
        case MESHFLOW_GEOMETRY_TYPES_VALUE_REAL: return v.val.real;
        default: return to_string(v.val.text);
    }
}

// n zeroed values for the bindings to free; none for n = 0, since their free helpers free
// only a non-empty list.
template <class T>
T* allocate(size_t n) {
    return n ? static_cast<T*>(std::calloc(n, sizeof(T))) : nullptr;
}

// describe(): the services as the bindings' records, allocated for the bindings to free.
inline void describe(const std::vector<Service>& services,
                     exports_meshflow_geometry_service_list_service_info_t* ret) {
    using info_t = exports_meshflow_geometry_service_service_info_t;
    using param_t = meshflow_geometry_types_param_info_t;
    ret->len = services.size();
    ret->ptr = allocate<info_t>(services.size());
    for (size_t i = 0; i < services.size(); ++i) {
        const Service& s = services[i];
        info_t& info = ret->ptr[i];
        info.name = owned(s.name);
        info.doc = owned(s.doc);
        bool is_check = s.run.index() == 1;
        info.kind = is_check ? MESHFLOW_GEOMETRY_TYPES_SERVICE_KIND_CHECK
                             : MESHFLOW_GEOMETRY_TYPES_SERVICE_KIND_FILTER;
        info.result_type.is_some = is_check;
        info.result_type.val = uint8_t(s.result);
        info.params.len = s.params.size();
        info.params.ptr = allocate<param_t>(s.params.size());
        for (size_t k = 0; k < s.params.size(); ++k) {
            const Param& p = s.params[k];
            param_t& out = info.params.ptr[k];
            out.name = owned(p.name);
            out.doc = owned(p.doc_text);
            out.ty = uint8_t(type_of(p.default_value));
            out.default_ = to_c(p.default_value);
            out.min = {p.min.has_value(), p.min.value_or(0)};
            out.max = {p.max.has_value(), p.max.value_or(0)};
            out.choices.len = p.choices.size();
            out.choices.ptr = allocate<plugin_string_t>(p.choices.size());
            for (size_t c = 0; c < p.choices.size(); ++c) out.choices.ptr[c] = owned(p.choices[c]);
        }
    }
}

// The name and parameters the bindings pass, copied, and the bindings' copies freed.
template <class List>
std::pair<std::string, std::vector<std::pair<std::string, Value>>> take_call(
    plugin_string_t* name, List* params, void (*free_params)(List*)) {
    std::vector<std::pair<std::string, Value>> values;
    for (size_t i = 0; i < params->len; ++i)
        values.emplace_back(to_string(params->ptr[i].name), from_c(params->ptr[i].value));
    std::string wanted = to_string(*name);
    plugin_string_free(name);
    free_params(params);
    return {std::move(wanted), std::move(values)};
}

// What a filter answers to one of the WIT's optional declarations with these parameters.
using Declaration = std::optional<uint32_t> (*)(const Service&, const Params&);

// The named filter's answer to a declaration (`locality.reach`, `blocks.block-triangles`),
// as the bindings' option<u32>: false (none) for a check or an unknown service.
template <class List>
bool declared(const std::vector<Service>& services, plugin_string_t* name, List* params,
              void (*free_params)(List*), Declaration answer, uint32_t* ret) {
    auto [wanted, values] = take_call(name, params, free_params);
    for (const Service& s : services) {
        if (s.name != wanted || s.run.index() != 0) continue;
        std::optional<uint32_t> given = answer(s, Params(std::move(values)));
        *ret = given.value_or(0);
        return given.has_value();
    }
    return false;
}

// reach(): the named filter's reach with these parameters, if it declared one.
inline bool reach(const std::vector<Service>& services, plugin_string_t* name,
                  exports_meshflow_geometry_locality_list_param_t* params, uint32_t* ret) {
    Declaration answer = [](const Service& s, const Params& p) -> std::optional<uint32_t> {
        if (!s.reach) return std::nullopt;
        return s.reach(p);
    };
    return declared(services, name, params, &exports_meshflow_geometry_locality_list_param_free,
                    answer, ret);
}

// block_triangles(): above how many triangles the named filter runs block by block with
// these parameters, if it declared blocks and gave a count (0 reads as none: whole).
inline bool block_triangles(const std::vector<Service>& services, plugin_string_t* name,
                            exports_meshflow_geometry_blocks_list_param_t* params, uint32_t* ret) {
    Declaration answer = [](const Service& s, const Params& p) -> std::optional<uint32_t> {
        if (!s.block_triangles) return std::nullopt;
        std::optional<uint32_t> n = s.block_triangles(p);
        if (n == 0u) return std::nullopt;
        return n;
    };
    return declared(services, name, params, &exports_meshflow_geometry_blocks_list_param_free,
                    answer, ret);
}

// run(): the named service on the mesh. The arguments are freed here and the borrowed mesh
// handle dropped before returning, as the component model requires; the outcome or the
// error message is allocated for the bindings to free.
inline bool run(const std::vector<Service>& services, plugin_string_t* name,
                exports_meshflow_geometry_service_borrow_mesh_t target,
                exports_meshflow_geometry_service_list_param_t* params,
                exports_meshflow_geometry_service_outcome_t* ret, plugin_string_t* err) {
    auto call = take_call(name, params, &exports_meshflow_geometry_service_list_param_free);
    const std::string& wanted = call.first;
    std::vector<std::pair<std::string, Value>>& values = call.second;

    Result<meshflow_geometry_types_option_value_t> outcome = [&]() -> decltype(outcome) {
        for (const Service& s : services) {
            if (s.name != wanted) continue;
            Mesh mesh(target);
            Params given(std::move(values));
            if (auto* filter = std::get_if<FilterFn>(&s.run)) {
                if (!*filter) return fail("service `" + wanted + "` has no function");
                Result<std::string> report = (*filter)(mesh, given);
                if (!report) return std::unexpected(report.error());
                ret->report = owned(*report);
                return meshflow_geometry_types_option_value_t{};
            }
            const CheckFn& check = std::get<CheckFn>(s.run);
            if (!check) return fail("service `" + wanted + "` has no function");
            Result<Value> value = check(mesh, given);
            if (!value) return std::unexpected(value.error());
            ret->report = owned("");
            return meshflow_geometry_types_option_value_t{true, to_c(*value)};
        }
        return fail("unknown service `" + wanted + "`");
    }();
    meshflow_geometry_mesh_mesh_drop_borrow(target);
    if (!outcome) {
#ifdef MESHFLOW_NATIVE
        native_failure_kind() = outcome.error().kind;
#endif
        *err = owned(outcome.error().message);
        return false;
    }
    ret->value = *outcome;
    return true;
}

}  // namespace detail

#ifdef MESHFLOW_NATIVE
// ---- native runs, for tests -------------------------------------------------------------------

// Services run in process on the host's recording store: built for the host's CPU with
// -DMESHFLOW_NATIVE and linked against libmeshflow_native.so (`make test`).
namespace native {

// A mesh held by the native library: loaded, made from arrays, or a run's result.
class MeshData {
public:
    MeshData(const MeshData& other) : raw_(meshflow_native_mesh_clone(other.raw_.get())) {}
    MeshData(MeshData&&) noexcept = default;
    MeshData& operator=(const MeshData& other) {
        if (this != &other) raw_.reset(meshflow_native_mesh_clone(other.raw_.get()));
        return *this;
    }
    MeshData& operator=(MeshData&&) noexcept = default;

    uint32_t vertex_count() const { return meshflow_native_mesh_vertex_count(raw_.get()); }
    uint32_t triangle_count() const { return meshflow_native_mesh_triangle_count(raw_.get()); }
    // x y z per vertex, a b c per triangle: views into the mesh, no copy.
    std::span<const float> positions() const {
        size_t len = 0;
        const float* data = meshflow_native_mesh_positions(raw_.get(), &len);
        return {data, len};
    }
    std::span<const uint32_t> triangles() const {
        size_t len = 0;
        const uint32_t* data = meshflow_native_mesh_triangles(raw_.get(), &len);
        return {data, len};
    }
    // The canonical content hash, as `meshflow hash` and `meshflow apply --json` give it.
    std::string hash() const {
        char hex[65];
        meshflow_native_mesh_hash(raw_.get(), hex);
        return hex;
    }
    // Writes binary PLY, OBJ or OFF (from the extension) as a host writes it.
    Result<> save(std::string_view path) const;

    const meshflow_native_mesh_t* raw() const { return raw_.get(); }
    explicit MeshData(meshflow_native_mesh_t* raw) : raw_(raw) {}

private:
    struct Free {
        void operator()(meshflow_native_mesh_t* m) const { meshflow_native_mesh_free(m); }
    };
    std::unique_ptr<meshflow_native_mesh_t, Free> raw_;
};

// What a native run gave.
struct Outcome {
    MeshData mesh;                 // compacted as a host compacts it (a check's: its input)
    std::string report;            // a filter's report
    std::optional<Value> value;    // a check's value
    uint64_t edits = 0;            // edited elements, as `meshflow apply` counts them
    std::vector<std::string> ops;  // the recorded operations' kinds ("set-positions", …)
};

namespace detail {

inline Error error(meshflow_native_error_t& e) {
    static constexpr ErrorKind kinds[] = {
        ErrorKind::Internal,       ErrorKind::File,      ErrorKind::InvalidMesh,
        ErrorKind::UnknownService, ErrorKind::Params,    ErrorKind::Failed,
        ErrorKind::BadResult,      ErrorKind::Crashed,   ErrorKind::Argument,
        ErrorKind::Internal};
    ErrorKind kind = e.kind < std::size(kinds) ? kinds[e.kind] : ErrorKind::Internal;
    // A service's failure keeps the kind it had inside the service (a refused edit's).
    if (kind == ErrorKind::Failed) kind = ::meshflow::detail::native_failure_kind();
    Error out{::meshflow::detail::to_string(e.message), kind};
    meshflow_native_error_free(&e);
    return out;
}

}  // namespace detail

inline Result<> MeshData::save(std::string_view path) const {
    meshflow_native_error_t e{};
    if (!meshflow_native_save(raw_.get(), path.data(), path.size(), &e)) return std::unexpected(detail::error(e));
    return {};
}

// Loads OBJ, PLY, OFF or STL (the format from the extension) with the host's readers.
inline Result<MeshData> load(std::string_view path) {
    meshflow_native_mesh_t* raw = nullptr;
    meshflow_native_error_t e{};
    if (!meshflow_native_load(path.data(), path.size(), &raw, &e)) return std::unexpected(detail::error(e));
    return MeshData(raw);
}

// A mesh from x y z per vertex (finite) and a b c per triangle (in range).
inline Result<MeshData> mesh(std::span<const float> xyz, std::span<const uint32_t> abc) {
    meshflow_native_mesh_t* raw = nullptr;
    meshflow_native_error_t e{};
    if (!meshflow_native_mesh_new(xyz.data(), xyz.size(), abc.data(), abc.size(), &raw, &e))
        return std::unexpected(detail::error(e));
    return MeshData(raw);
}

// Runs `service` of this program's plugin (MESHFLOW_EXPORT_PLUGIN) on a copy of `mesh`, as
// a host runs it: parameters not given take their defaults and every one is checked against
// the description (ErrorKind::Params), a check gets a read-only mesh, every edit is checked
// and recorded by the host's store, a service's failure keeps its kind (a refused edit's,
// through MESHFLOW_TRY) and the host's message. Integers are int64_t: {"iterations", int64_t{5}}.
inline Result<Outcome> run(std::string_view service, const MeshData& mesh,
                           const std::vector<std::pair<std::string, Value>>& params = {}) {
    std::vector<meshflow_geometry_types_param_t> given(params.size());
    for (size_t i = 0; i < params.size(); ++i) {
        // Borrowed by the library: strings point into `params`.
        auto borrow = [](const std::string& s) {
            return plugin_string_t{reinterpret_cast<uint8_t*>(const_cast<char*>(s.data())), s.size()};
        };
        given[i].name = borrow(params[i].first);
        const Value& v = params[i].second;
        given[i].value.tag = uint8_t(v.index());
        switch (v.index()) {
            case 0: given[i].value.val.boolean = std::get<bool>(v); break;
            case 1: given[i].value.val.integer = std::get<int64_t>(v); break;
            case 2: given[i].value.val.real = std::get<double>(v); break;
            default: given[i].value.val.text = borrow(std::get<std::string>(v)); break;
        }
    }
    ::meshflow::detail::native_failure_kind() = ErrorKind::Failed;
    meshflow_native_outcome_t out{};
    meshflow_native_error_t e{};
    if (!meshflow_native_run(&exports_meshflow_geometry_service_describe,
                             &exports_meshflow_geometry_service_run, service.data(),
                             service.size(), mesh.raw(), given.data(), given.size(), &out, &e))
        return std::unexpected(detail::error(e));
    Outcome outcome{MeshData(out.mesh), ::meshflow::detail::to_string(out.report), std::nullopt,
                    out.edits, {}};
    out.mesh = nullptr;  // now the outcome's
    if (out.value.is_some) outcome.value = ::meshflow::detail::from_c(out.value.val);
    for (size_t i = 0; i < out.ops.len; ++i)
        outcome.ops.push_back(::meshflow::detail::to_string(out.ops.ptr[i]));
    meshflow_native_outcome_free(&out);
    return outcome;
}

}  // namespace native
#endif

}  // namespace meshflow

#if defined(__wasm__)
#define MESHFLOW_DETAIL_STACK_CHECK_SYMBOLS                                                    \
    extern "C" __attribute__((weak)) uintptr_t __stack_chk_guard = 0x6d657368u;                \
    extern "C" __attribute__((weak, noreturn)) void __stack_chk_fail(void) { __builtin_trap(); }
#else
// Natively the C library has them.
#define MESHFLOW_DETAIL_STACK_CHECK_SYMBOLS
#endif

// Exports the services returned by `std::vector<meshflow::Service> services()` as this
// component's meshflow:geometry/service interface, their reach (`Service::local`) as its
// meshflow:geometry/locality, and their block size (`Service::blocks`) as its
// meshflow:geometry/blocks.
// It also gives weak definitions of the stack-protector symbols that Debian's wasm32
// compiler-rt (128-bit division, which std::format uses) refers to and wasi-libc lacks.
#define MESHFLOW_EXPORT_PLUGIN(services_fn)                                                    \
    MESHFLOW_DETAIL_STACK_CHECK_SYMBOLS                                                        \
    extern "C" void exports_meshflow_geometry_service_describe(                               \
        exports_meshflow_geometry_service_list_service_info_t* ret) {                          \
        ::meshflow::detail::describe(services_fn(), ret);                                      \
    }                                                                                          \
    extern "C" bool exports_meshflow_geometry_service_run(                                     \
        plugin_string_t* name, exports_meshflow_geometry_service_borrow_mesh_t target,         \
        exports_meshflow_geometry_service_list_param_t* params,                                \
        exports_meshflow_geometry_service_outcome_t* ret, plugin_string_t* err) {              \
        return ::meshflow::detail::run(services_fn(), name, target, params, ret, err);         \
    }                                                                                          \
    extern "C" bool exports_meshflow_geometry_locality_reach(                                  \
        plugin_string_t* name, exports_meshflow_geometry_locality_list_param_t* params,        \
        uint32_t* ret) {                                                                       \
        return ::meshflow::detail::reach(services_fn(), name, params, ret);                    \
    }                                                                                          \
    extern "C" bool exports_meshflow_geometry_blocks_block_triangles(                          \
        plugin_string_t* name, exports_meshflow_geometry_blocks_list_param_t* params,          \
        uint32_t* ret) {                                                                       \
        return ::meshflow::detail::block_triangles(services_fn(), name, params, ret);          \
    }

// Early return for results, like Rust's `?`: `auto xyz = MESHFLOW_TRY(mesh.position(v));`
// gives the value, or returns the error from the enclosing function (any function returning
// a meshflow::Result). For a Result<> it is a statement: `MESHFLOW_TRY(mesh.clear());`.
// (A statement expression, as clang and GCC support.)
#define MESHFLOW_TRY(...)                                                                       \
    ({                                                                                          \
        auto meshflow_try_result_ = (__VA_ARGS__);                                              \
        if (!meshflow_try_result_)                                                              \
            return ::std::unexpected(::std::move(meshflow_try_result_).error());                \
        ::meshflow::detail::take_value(::std::move(meshflow_try_result_));                      \
    })
