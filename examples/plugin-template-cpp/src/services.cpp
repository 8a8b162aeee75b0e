// The plugin's services: they only move data between the host and the algorithm.
#include <meshflow.hpp>

#include <string>

#include "taubin.hpp"

namespace {

meshflow::Result<std::string> taubin_smoothing(const meshflow::Mesh& mesh,
                                               const meshflow::Params& params) {
    // The host has checked the parameters against the description below.
    double lambda = params.get_real("lambda");
    double mu = params.get_real("mu");
    int64_t iterations = params.get_integer("iterations");
    // Read both arrays once (no copy on this side), smooth, write back in one edit.
    std::vector<float> smoothed =
        taubin::smooth(mesh.positions(), mesh.triangles(), lambda, mu, uint32_t(iterations));
    MESHFLOW_TRY(mesh.set_positions(smoothed));
    // (std::format, and meshflow::fail("{}", …), work too, but add ~500 KB to the module.)
    return std::to_string(iterations) + " Taubin iteration(s) over " +
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
            .param(Param::integer("iterations", 10).range(1, 1000).doc("lambda|mu steps."))
            // Each lambda|mu step reads one ring further: a host may run it on partitions
            // of a mesh too large for one sandbox.
            .local([](const meshflow::Params& p) {
                return uint32_t(2 * p.get_integer("iterations"));
            }),
    };
}

}  // namespace

MESHFLOW_EXPORT_PLUGIN(services)
