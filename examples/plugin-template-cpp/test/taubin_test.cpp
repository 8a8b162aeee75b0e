// A native test of the service (`make test`): taubin-smoothing-cpp run in process on the
// host's own recording store, so every edit is checked as a host checks it, on the mesh file
// given as the argument (test/patch.obj, or `make test TEST_MESH=bunny.obj`).
#include <meshflow.hpp>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using meshflow::native::MeshData;

int failures = 0;

void expect(bool ok, const std::string& what) {
    if (!ok) {
        std::fprintf(stderr, "FAILED: %s\n", what.c_str());
        ++failures;
    }
}

// Vertices on an edge that one triangle alone has: worked out here, apart from the service.
std::vector<bool> boundary(const MeshData& mesh) {
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    auto abc = mesh.triangles();
    for (size_t t = 0; t + 2 < abc.size(); t += 3) {
        uint32_t c[3] = {abc[t], abc[t + 1], abc[t + 2]};
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
        for (int k = 0; k < 3; ++k) ++edges[std::minmax(c[k], c[(k + 1) % 3])];
    }
    std::vector<bool> on(mesh.vertex_count(), false);
    for (auto& [edge, count] : edges)
        if (count == 1) on[edge.first] = on[edge.second] = true;
    return on;
}

}  // namespace

int main(int argc, char** argv) {
    const char* path = argc > 1 ? argv[1] : "test/patch.obj";
    auto input = meshflow::native::load(path);
    if (!input) {
        std::fprintf(stderr, "%s\n", input.error().message.c_str());
        return 1;
    }
    auto out = meshflow::native::run("taubin-smoothing-cpp", *input, {{"iterations", int64_t{5}}});
    if (!out) {
        std::fprintf(stderr, "the run failed: %s\n", out.error().message.c_str());
        return 1;
    }
    const MeshData& smoothed = out->mesh;

    // Smoothing moves vertices and nothing else: one bulk edit, counts and triangles kept.
    expect(smoothed.vertex_count() == input->vertex_count(), "the vertex count is unchanged");
    expect(std::ranges::equal(smoothed.triangles(), input->triangles()), "the triangles stay");
    expect(out->ops == std::vector<std::string>{"set-positions"}, "one set-positions edit");
    expect(out->edits == input->vertex_count(), "every vertex is written once");

    // Interior vertices move; boundary vertices keep their bits.
    std::vector<bool> pinned = boundary(*input);
    auto before = input->positions();
    auto after = smoothed.positions();
    size_t moved = 0, pinned_moved = 0;
    for (size_t v = 0; v < pinned.size(); ++v) {
        bool same = std::memcmp(&before[3 * v], &after[3 * v], 3 * sizeof(float)) == 0;
        if (!same) ++(pinned[v] ? pinned_moved : moved);
    }
    expect(moved > 0, "interior vertices moved");
    expect(pinned_moved == 0, std::to_string(pinned_moved) + " boundary vertices moved");

    // The host's parameter checks: a value out of range, a value of the wrong type.
    auto refused = meshflow::native::run("taubin-smoothing-cpp", *input, {{"iterations", int64_t{0}}});
    expect(!refused && refused.error().kind == meshflow::ErrorKind::Params,
           "iterations=0 is refused as out of range");
    auto wrong = meshflow::native::run("taubin-smoothing-cpp", *input, {{"mu", true}});
    expect(!wrong && wrong.error().kind == meshflow::ErrorKind::Params,
           "a boolean mu is refused");

    std::printf("taubin-smoothing-cpp on %s: %u vertices, %zu moved, %llu edits, result %s\n",
                path, smoothed.vertex_count(), moved, (unsigned long long)out->edits,
                smoothed.hash().c_str());
    std::printf("%s: %d failed\n", failures ? "FAILED" : "ok", failures);
    return failures ? 1 : 0;
}
