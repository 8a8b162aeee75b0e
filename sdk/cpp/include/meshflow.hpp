// meshflow.hpp: write meshflow plugins in C++ (C++23). The C++ twin of the Rust SDK's
// `Mesh` and `export_plugin!`, over the C bindings that wit-bindgen generates from meshflow's
// WIT (../generated/plugin.h):
//
//   - `meshflow::Mesh`: the host's mesh, read as spans-ready vectors of floats and ids,
//     edited in bulk; every edit is recorded by the host, a refused one comes back as an
//     error value;
//   - `meshflow::Service`, `meshflow::Param`: services and typed parameters described in
//     code; `meshflow::Params` reads them;
//   - `MESHFLOW_EXPORT_PLUGIN(services)`: exports a `std::vector<Service> services()`.
//
// Errors are return values (`meshflow::Result<T>` = `std::expected<T, Error>`), so
// plugins build with -fno-exceptions. Link ../generated/plugin.c and
// ../generated/plugin_component_type.o, build for wasm32-wasi (preview 1) as a reactor, then
// `meshflow plugin componentize CORE.wasm -o PLUGIN.wasm`.
#pragma once

extern "C" {
#include "plugin.h"
}

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace meshflow {

// ---- errors ---------------------------------------------------------------------------------

// Why a service failed: a message the host shows to the user.
struct Error {
    std::string message;
};

template <class T = void>
using Result = std::expected<T, Error>;

inline std::unexpected<Error> fail(std::string message) {
    return std::unexpected(Error{std::move(message)});
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
    static const char* const kinds[] = {"invalid vertex",   "invalid triangle",
                                        "invalid edge",     "repeated vertex",
                                        "invalid argument", "not applicable",
                                        "read-only mesh"};
    const char* kind = e.kind < std::size(kinds) ? kinds[e.kind] : "refused";
    Error error{std::string("edit refused (") + kind + "): " + to_string(e.message)};
    meshflow_geometry_mesh_edit_error_free(&e);
    return error;
}

template <class List, class T>
List list_of(std::span<const T> items) {
    return List{const_cast<T*>(items.data()), items.size()};
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
    // Inclusive bounds; the host refuses values outside them.
    Param range(double lo, double hi) && {
        min = lo;
        max = hi;
        return std::move(*this);
    }
    Param doc(std::string text) && {
        doc_text = std::move(text);
        return std::move(*this);
    }
};

// ---- the mesh ---------------------------------------------------------------------------------

// A borrowed handle to the mesh a service runs on. Read arrays once, compute, write edits
// back in bulk: each call crosses the sandbox boundary (~100 ns), each element is copied.
class Mesh {
public:
    explicit Mesh(meshflow_geometry_mesh_borrow_mesh_t raw) : raw_(raw) {}

    // Vertex and triangle ids in use (removed ones included), and live counts.
    uint32_t vertex_slots() const { return meshflow_geometry_mesh_method_mesh_vertex_slots(raw_); }
    uint32_t triangle_slots() const { return meshflow_geometry_mesh_method_mesh_triangle_slots(raw_); }
    uint32_t vertex_count() const { return meshflow_geometry_mesh_method_mesh_vertex_count(raw_); }
    uint32_t triangle_count() const { return meshflow_geometry_mesh_method_mesh_triangle_count(raw_); }

    // x y z per vertex slot.
    std::vector<float> positions() const {
        plugin_list_f32_t list;
        meshflow_geometry_mesh_method_mesh_positions(raw_, &list);
        return take<float>(list);
    }
    // a b c per triangle slot; a removed triangle reads REMOVED three times.
    std::vector<uint32_t> triangles() const {
        plugin_list_u32_t list;
        meshflow_geometry_mesh_method_mesh_triangles(raw_, &list);
        return take<uint32_t>(list);
    }

    // Moves every vertex: 3 values per vertex slot. One edit, coded as displacements.
    Result<> set_positions(std::span<const float> xyz) const {
        auto list = detail::list_of<plugin_list_f32_t>(xyz);
        return unit(meshflow_geometry_mesh_method_mesh_set_positions(raw_, &list, &error_));
    }
    // Moves ids[i] to xyz[3i .. 3i + 3].
    Result<> move_vertices(std::span<const uint32_t> ids, std::span<const float> xyz) const {
        auto i = detail::list_of<plugin_list_u32_t>(ids);
        auto p = detail::list_of<plugin_list_f32_t>(xyz);
        return unit(meshflow_geometry_mesh_method_mesh_move_vertices(raw_, &i, &p, &error_));
    }
    // Appends xyz.size() / 3 vertices; the first new id.
    Result<uint32_t> add_vertices(std::span<const float> xyz) const {
        auto list = detail::list_of<plugin_list_f32_t>(xyz);
        uint32_t first;
        return id(meshflow_geometry_mesh_method_mesh_add_vertices(raw_, &list, &first, &error_), first);
    }
    Result<> remove_vertices(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_remove_vertices(raw_, &list, &error_));
    }
    // Appends abc.size() / 3 triangles of live, distinct corners; the first new id.
    Result<uint32_t> add_triangles(std::span<const uint32_t> abc) const {
        auto list = detail::list_of<plugin_list_u32_t>(abc);
        uint32_t first;
        return id(meshflow_geometry_mesh_method_mesh_add_triangles(raw_, &list, &first, &error_), first);
    }
    Result<> remove_triangles(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_remove_triangles(raw_, &list, &error_));
    }
    Result<> flip_triangles(std::span<const uint32_t> ids) const {
        auto list = detail::list_of<plugin_list_u32_t>(ids);
        return unit(meshflow_geometry_mesh_method_mesh_flip_triangles(raw_, &list, &error_));
    }
    // Applies a row-major 3x4 affine map to every vertex.
    Result<> transform(std::span<const float, 12> matrix) const {
        auto list = detail::list_of<plugin_list_f32_t>(std::span<const float>(matrix));
        return unit(meshflow_geometry_mesh_method_mesh_transform(raw_, &list, &error_));
    }

private:
    template <class T, class List>
    static std::vector<T> take(List& list) {
        std::vector<T> out(list.ptr, list.ptr + list.len);
        std::free(list.ptr);
        return out;
    }
    Result<> unit(bool ok) const {
        if (ok) return {};
        return std::unexpected(detail::edit_error(error_));
    }
    Result<uint32_t> id(bool ok, uint32_t value) const {
        if (ok) return value;
        return std::unexpected(detail::edit_error(error_));
    }

    meshflow_geometry_mesh_borrow_mesh_t raw_;
    mutable meshflow_geometry_mesh_edit_error_t error_{};
};

// ---- services ---------------------------------------------------------------------------------

// A filter edits the mesh and returns a short report of what it did.
using FilterFn = Result<std::string> (*)(const Mesh&, const Params&);
// A check reads the mesh (the host refuses edits) and returns a value.
using CheckFn = Result<Value> (*)(const Mesh&, const Params&);

// One service of a plugin: its description and the function that runs it.
struct Service {
    std::string name, doc;
    std::variant<FilterFn, CheckFn> run;
    ValueType result = ValueType::Integer;  // checks only
    std::vector<Param> params;

    static Service filter(std::string name, std::string doc, FilterFn f) {
        return {std::move(name), std::move(doc), f, ValueType::Integer, {}};
    }
    static Service check(std::string name, std::string doc, ValueType result, CheckFn f) {
        return {std::move(name), std::move(doc), f, result, {}};
    }
    Service param(Param p) && {
        params.push_back(std::move(p));
        return std::move(*this);
    }
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

template <class T>
T* allocate(size_t n) {
    return static_cast<T*>(std::calloc(n ? n : 1, sizeof(T)));
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

// run(): the named service on the mesh. The arguments are freed here and the borrowed mesh
// handle dropped before returning, as the component model requires; the outcome or the
// error message is allocated for the bindings to free.
inline bool run(const std::vector<Service>& services, plugin_string_t* name,
                exports_meshflow_geometry_service_borrow_mesh_t target,
                exports_meshflow_geometry_service_list_param_t* params,
                exports_meshflow_geometry_service_outcome_t* ret, plugin_string_t* err) {
    std::string wanted = to_string(*name);
    std::vector<std::pair<std::string, Value>> values;
    for (size_t i = 0; i < params->len; ++i)
        values.emplace_back(to_string(params->ptr[i].name), from_c(params->ptr[i].value));
    plugin_string_free(name);
    exports_meshflow_geometry_service_list_param_free(params);

    Result<meshflow_geometry_types_option_value_t> outcome = [&]() -> decltype(outcome) {
        for (const Service& s : services) {
            if (s.name != wanted) continue;
            Mesh mesh(target);
            Params given(std::move(values));
            if (auto* filter = std::get_if<FilterFn>(&s.run)) {
                Result<std::string> report = (*filter)(mesh, given);
                if (!report) return std::unexpected(report.error());
                ret->report = owned(*report);
                return meshflow_geometry_types_option_value_t{};
            }
            Result<Value> value = std::get<CheckFn>(s.run)(mesh, given);
            if (!value) return std::unexpected(value.error());
            ret->report = owned("");
            return meshflow_geometry_types_option_value_t{true, to_c(*value)};
        }
        return fail("unknown service `" + wanted + "`");
    }();
    meshflow_geometry_mesh_mesh_drop_borrow(target);
    if (!outcome) {
        *err = owned(outcome.error().message);
        return false;
    }
    ret->value = *outcome;
    return true;
}

}  // namespace detail
}  // namespace meshflow

// Exports the services returned by `std::vector<meshflow::Service> services()` as this
// component's meshflow:geometry/service interface.
#define MESHFLOW_EXPORT_PLUGIN(services_fn)                                                    \
    extern "C" void exports_meshflow_geometry_service_describe(                               \
        exports_meshflow_geometry_service_list_service_info_t* ret) {                          \
        ::meshflow::detail::describe(services_fn(), ret);                                      \
    }                                                                                          \
    extern "C" bool exports_meshflow_geometry_service_run(                                     \
        plugin_string_t* name, exports_meshflow_geometry_service_borrow_mesh_t target,         \
        exports_meshflow_geometry_service_list_param_t* params,                                \
        exports_meshflow_geometry_service_outcome_t* ret, plugin_string_t* err) {              \
        return ::meshflow::detail::run(services_fn(), name, target, params, ret, err);         \
    }
