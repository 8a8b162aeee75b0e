#include "taubin.hpp"

#include <algorithm>
#include <utility>

namespace taubin {
namespace {

struct Neighbours {
    std::vector<uint32_t> offsets;  // row v is items[offsets[v] .. offsets[v + 1]]
    std::vector<uint32_t> items;    // ascending, distinct, per row
};

// Every vertex joined to v by a triangle edge: the other in-range corners of its triangles.
Neighbours neighbours_of(size_t vertex_count, std::span<const uint32_t> triangles) {
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    pairs.reserve(triangles.size() * 2);
    for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                uint32_t a = triangles[t + i], b = triangles[t + j];
                if (a != b && a < vertex_count && b < vertex_count) pairs.emplace_back(a, b);
            }
        }
    }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    Neighbours n{std::vector<uint32_t>(vertex_count + 1, 0), {}};
    n.items.reserve(pairs.size());
    for (auto [a, b] : pairs) {
        ++n.offsets[a + 1];
        n.items.push_back(b);
    }
    for (size_t v = 0; v < vertex_count; ++v) n.offsets[v + 1] += n.offsets[v];
    return n;
}

// Vertices on an edge that only one proper triangle (three distinct in-range corners) has.
std::vector<bool> boundary_vertices(size_t vertex_count, std::span<const uint32_t> triangles) {
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
        uint32_t c[3] = {triangles[t], triangles[t + 1], triangles[t + 2]};
        bool proper = c[0] != c[1] && c[1] != c[2] && c[0] != c[2] && c[0] < vertex_count &&
                      c[1] < vertex_count && c[2] < vertex_count;
        if (!proper) continue;
        for (int k = 0; k < 3; ++k) edges.emplace_back(std::minmax(c[k], c[(k + 1) % 3]));
    }
    std::sort(edges.begin(), edges.end());
    std::vector<bool> boundary(vertex_count, false);
    for (size_t i = 0; i < edges.size();) {
        size_t j = i;
        while (j < edges.size() && edges[j] == edges[i]) ++j;
        if (j - i == 1) boundary[edges[i].first] = boundary[edges[i].second] = true;
        i = j;
    }
    return boundary;
}

}  // namespace

std::vector<float> smooth(std::span<const float> positions, std::span<const uint32_t> triangles,
                          double lambda, double mu, uint32_t iterations) {
    const size_t n = positions.size() / 3;
    const Neighbours nb = neighbours_of(n, triangles);
    const std::vector<bool> pinned = boundary_vertices(n, triangles);
    std::vector<float> current(positions.begin(), positions.begin() + 3 * n);
    std::vector<double> laplacian(3 * n);
    for (uint32_t it = 0; it < iterations; ++it) {
        for (double factor : {lambda, mu}) {
            for (size_t v = 0; v < n; ++v) {
                double sum[3] = {0, 0, 0}, total = 0;
                for (uint32_t i = nb.offsets[v]; i < nb.offsets[v + 1]; ++i) {
                    const float* p = &current[3 * size_t(nb.items[i])];
                    for (int k = 0; k < 3; ++k) sum[k] += 1.0 * double(p[k]);
                    total += 1.0;
                }
                for (int k = 0; k < 3; ++k)
                    laplacian[3 * v + k] = total > 0 ? sum[k] / total - double(current[3 * v + k]) : 0.0;
            }
            for (size_t v = 0; v < n; ++v) {
                if (pinned[v]) continue;
                for (int k = 0; k < 3; ++k) {
                    size_t i = 3 * v + k;
                    current[i] = float(double(current[i]) + factor * laplacian[i]);
                }
            }
        }
    }
    return current;
}

}  // namespace taubin
