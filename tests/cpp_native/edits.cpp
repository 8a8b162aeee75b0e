// Services whose edits a host refuses (tests/cpp_native.rs): each runs both natively
// (edits_test.cpp, `make test`) and as a .wasm on a host, and both must refuse it alike.
#include <meshflow.hpp>

#include <string>

using meshflow::Mesh;
using meshflow::Params;
using meshflow::Result;
using meshflow::Value;

std::vector<meshflow::Service> services() {
    using meshflow::Service;
    using meshflow::ValueType;
    return {
        // A triangle with a repeated corner.
        Service::filter("repeat-corner", "Adds a triangle with a repeated vertex.",
                        [](const Mesh& mesh, const Params&) -> Result<std::string> {
                            MESHFLOW_TRY(mesh.add_triangle(0, 0, 1));
                            return "added";
                        }),
        // A vertex edited after it was removed.
        Service::filter("move-removed", "Moves a vertex it removed.",
                        [](const Mesh& mesh, const Params&) -> Result<std::string> {
                            MESHFLOW_TRY(mesh.remove_vertex(0));
                            MESHFLOW_TRY(mesh.move_vertex(0, 1, 2, 3));
                            return "moved";
                        }),
        // A check may read, not edit: the refusal as its value...
        Service::check("edit-in-check", "Tries to clear the mesh, says what the host said.",
                       ValueType::Text,
                       [](const Mesh& mesh, const Params&) -> Result<Value> {
                           auto refused = mesh.clear();
                           if (refused) return meshflow::fail("a check cleared the mesh");
                           return Value{refused.error().message};
                       }),
        // An attribute of the wrong shape (quality is 1 × f32).
        Service::filter("bad-attribute-shape", "Writes a two-number quality.",
                        [](const Mesh& mesh, const Params&) -> Result<std::string> {
                            std::vector<float> q(2 * mesh.vertex_slots(), 0.5f);
                            MESHFLOW_TRY(mesh.set_attribute(meshflow::Domain::Vertex, "quality", 2,
                                                            std::nullopt, q));
                            return "written";
                        }),
        // A check writing quality.
        Service::check("quality-in-check", "Writes quality, failing as the host refuses it.",
                       ValueType::Integer,
                       [](const Mesh& mesh, const Params&) -> Result<Value> {
                           std::vector<float> q(mesh.vertex_slots(), 1.0f);
                           MESHFLOW_TRY(mesh.set_quality(std::nullopt, q));
                           return Value{int64_t{0}};
                       }),
        // Quality and colours written, read back, and reaching the result alike natively and
        // on a host.
        Service::filter("write-attributes", "Writes quality and colours from the heights.",
                        [](const Mesh& mesh, const Params&) -> Result<std::string> {
                            auto xyz = mesh.positions();
                            uint32_t n = mesh.vertex_slots();
                            std::vector<float> q(n);
                            std::vector<std::array<uint8_t, 4>> rgba(n);
                            for (uint32_t v = 0; v < n; ++v) {
                                q[v] = xyz[3 * v + 1];
                                rgba[v] = {uint8_t(v % 251), uint8_t(v % 13), 7, 255};
                            }
                            MESHFLOW_TRY(mesh.set_quality(std::nullopt, q));
                            std::vector<uint32_t> ids{0, 1};
                            MESHFLOW_TRY(mesh.set_vertex_colors(std::nullopt, rgba));
                            MESHFLOW_TRY(mesh.set_vertex_colors(
                                ids, std::vector<std::array<uint8_t, 4>>{{9, 9, 9, 9}, {8, 8, 8, 8}}));
                            auto back = mesh.quality();
                            if (!back || *back != q) return meshflow::fail("quality read back differs");
                            return std::format("{} attributes", mesh.attributes().size());
                        }),
        // ... and as its failure.
        Service::check("clear-in-check", "Clears the mesh, failing as the host refuses it.",
                       ValueType::Integer,
                       [](const Mesh& mesh, const Params&) -> Result<Value> {
                           MESHFLOW_TRY(mesh.clear());
                           return Value{int64_t{mesh.triangle_count()}};
                       }),
    };
}

MESHFLOW_EXPORT_PLUGIN(services)
