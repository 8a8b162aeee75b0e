// Taubin smoothing over flat arrays, free of any meshflow type: the algorithm alone, so it
// can be tested natively and reused.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace taubin {

// `iterations` lambda|mu steps over `positions` (x y z per vertex; `triangles` a b c per
// triangle, removed ones all 0xFFFFFFFF). Boundary vertices and vertices without neighbours
// stay. Each half-step moves every free vertex by `factor` times its uniform Laplacian,
// summed in double over its neighbours in ascending order and rounded to float once: the
// same operations, in the same order, as meshflow's Rust `taubin-smoothing`.
std::vector<float> smooth(std::span<const float> positions, std::span<const uint32_t> triangles,
                          double lambda, double mu, uint32_t iterations);

}  // namespace taubin
