// The plugin's services: they only move data between the host and the algorithm.
#include <meshflow.hpp>

#include <string>

#include "taubin.hpp"

namespace {

meshflow::Result<std::string> taubin_smoothing(const meshflow::Mesh& mesh,
                                               const meshflow::Params& params) {
    auto lambda = params.real("lambda");
    auto mu = params.real("mu");
    auto iterations = params.integer("iterations");
    if (!lambda) return std::unexpected(lambda.error());
    if (!mu) return std::unexpected(mu.error());
    if (!iterations) return std::unexpected(iterations.error());
    std::vector<float> smoothed =
        taubin::smooth(mesh.positions(), mesh.triangles(), *lambda, *mu, uint32_t(*iterations));
    // One move-all edit for the whole step.
    if (auto done = mesh.set_positions(smoothed); !done) return std::unexpected(done.error());
    return std::to_string(*iterations) + " Taubin iteration(s) over " +
           std::to_string(mesh.vertex_count()) + " vertices (C++)";
}

std::vector<meshflow::Service> services() {
    using meshflow::Param;
    return {
        meshflow::Service::filter(
            "taubin-smoothing-cpp",
            "Smooths without shrinking (Taubin's lambda|mu), written in C++. Boundary vertices "
            "stay.",
            taubin_smoothing)
            .param(Param::real("lambda", 0.5).range(1e-6, 1.0).doc("Shrinking step."))
            .param(Param::real("mu", -0.53).range(-1.0, -1e-6).doc("Inflating step (negative)."))
            .param(Param::integer("iterations", 10).range(1, 1000).doc("lambda|mu steps.")),
    };
}

}  // namespace

MESHFLOW_EXPORT_PLUGIN(services)
