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
