// Exercises every part of meshflow.hpp against a real host (tests/cpp_sdk.rs): each Mesh
// wrapper (attributes included), MESHFLOW_TRY on values and on Result<>, formatted fail(), direct parameter
// getters, builders on named objects, capturing lambdas as services, and a filter declared
// to run in blocks (Service::blocks).
#include <meshflow.hpp>

#include <algorithm>
#include <set>
#include <string>
#include <utility>

using meshflow::half_edge;
using meshflow::Mesh;
using meshflow::Params;
using meshflow::Result;

namespace {

// Every edit of the WIT mesh, once, on a mesh of at least 200 triangles.
Result<std::string> edits(const Mesh& mesh, const Params& params) {
    int64_t rounds = params.get_integer("rounds");
    std::string log;
    auto note = [&](std::string_view what, uint32_t n) { log += std::format("{}={} ", what, n); };

    auto p0 = MESHFLOW_TRY(mesh.position(0));
    auto t0 = MESHFLOW_TRY(mesh.triangle(0));
    if (!mesh.is_vertex_live(t0[0]) || !mesh.is_triangle_live(0)) return meshflow::fail("dead");
    MESHFLOW_TRY(mesh.move_vertex(0, p0[0], p0[1], p0[2] + 0.001f));

    // An isolated square: a triangle, extended across its diagonal, the diagonal swapped,
    // both flipped, moved, then removed whole.
    uint32_t a = MESHFLOW_TRY(mesh.add_vertex(10, 0, 0));
    uint32_t b = MESHFLOW_TRY(mesh.add_vertices(std::vector<float>{11, 0, 0, 11, 1, 0, 10, 1, 0}));
    uint32_t lone = MESHFLOW_TRY(mesh.add_triangle(a, b, b + 1));
    uint32_t far = MESHFLOW_TRY(mesh.extend_edge(half_edge(lone, 2), b + 2));
    note("extended", far);
    MESHFLOW_TRY(mesh.swap_edge(half_edge(lone, 2)));
    MESHFLOW_TRY(mesh.flip_triangle(far));
    MESHFLOW_TRY(mesh.flip_triangles(std::vector<uint32_t>{far}));
    const float shift[12] = {1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0};
    MESHFLOW_TRY(mesh.transform_component(lone, shift));
    // The square is a piece of its own, listed by its first triangle.
    bool listed = false;
    for (const meshflow::Component& c : mesh.components()) {
        listed = listed || (c.first_triangle == lone && c.triangles == 2);
    }
    if (!listed) return meshflow::fail("components() does not list the square at {}", lone);
    MESHFLOW_TRY(mesh.remove_component(lone));
    if (mesh.is_triangle_live(far)) return meshflow::fail("remove_component left {}", far);

    for (int64_t r = 0; r < rounds; ++r) {
        uint32_t t = 10 + uint32_t(r) * 20;
        uint32_t v = MESHFLOW_TRY(mesh.split_triangle(t));
        uint32_t w = MESHFLOW_TRY(mesh.split_triangle_at(t + 1, p0[0], p0[1], p0[2]));
        uint32_t x = MESHFLOW_TRY(mesh.split_edge(half_edge(t + 2, 0)));
        uint32_t y = MESHFLOW_TRY(mesh.split_edge_at(half_edge(t + 3, 1), p0[0], p0[1], p0[2]));
        note("split", v + w + x + y);
        MESHFLOW_TRY(mesh.collapse_edge(half_edge(t + 5, 0)));
    }
    uint32_t more = MESHFLOW_TRY(mesh.add_triangles(std::vector<uint32_t>{1, 2, 3}));
    MESHFLOW_TRY(mesh.remove_triangle(more));
    MESHFLOW_TRY(mesh.remove_triangles(std::vector<uint32_t>{more - 1}));
    MESHFLOW_TRY(mesh.remove_vertex(7));
    MESHFLOW_TRY(mesh.remove_vertices(std::vector<uint32_t>{8}));
    MESHFLOW_TRY(mesh.move_vertices(std::vector<uint32_t>{9}, std::vector<float>{0, 0, 0}));

    // A refused edit is a value, with the host's reason.
    auto refused = mesh.remove_triangle(0xFFFFFFF0u);
    if (refused) return meshflow::fail("a dead triangle was removed");
    log += refused.error().message + " ";

    // positions() and triangles() hand over the host's arrays without a copy.
    meshflow::Array<float> xyz = mesh.positions();
    meshflow::Array<uint32_t> abc = mesh.triangles();
    for (float& c : xyz) c *= 2;
    MESHFLOW_TRY(mesh.set_positions(xyz));
    const float unit[12] = {0.5f, 0, 0, 0, 0, 0.5f, 0, 0, 0, 0, 0.5f, 0};
    MESHFLOW_TRY(mesh.transform(unit));
    std::span<const uint32_t> ids = abc;
    note("removed", uint32_t(mesh.removed_vertices().size()));
    note("slots", uint32_t(ids.size() / 3));

    // The derived connectivity agrees with the triangles it comes from: one edge per
    // distinct corner pair of the proper live triangles, opposites that point back.
    std::set<std::pair<uint32_t, uint32_t>> distinct;
    for (size_t t = 0; t < ids.size() / 3; ++t) {
        uint32_t c[3] = {ids[3 * t], ids[3 * t + 1], ids[3 * t + 2]};
        if (c[0] == meshflow::REMOVED || c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
        for (int k = 0; k < 3; ++k) distinct.insert(std::minmax(c[k], c[(k + 1) % 3]));
    }
    meshflow::Array<uint32_t> opposite = mesh.half_edge_opposites();
    meshflow::Array<uint8_t> kinds = mesh.half_edge_kinds();
    bool pointing_back = opposite.size() == ids.size() && kinds.size() == ids.size();
    for (size_t h = 0; pointing_back && h < opposite.size(); ++h) {
        uint32_t o = opposite[h];
        pointing_back = o == meshflow::REMOVED || (opposite[o] == h && kinds[h] >= 2 && kinds[h] <= 3);
    }
    note("edges-agree", uint32_t(mesh.edges().size() == distinct.size()));
    note("opposites-agree", uint32_t(pointing_back));
    return log;
}

// Every attribute call: typed and generic writes, reads back, a removal, a refusal.
Result<std::string> attributes(const Mesh& mesh, const Params&) {
    using meshflow::Domain;
    uint32_t n = mesh.vertex_slots();
    if (mesh.quality() || !mesh.attributes().empty()) return meshflow::fail("attributes already");
    std::vector<float> quality(n);
    std::vector<std::array<uint8_t, 4>> rgba(n);
    for (uint32_t v = 0; v < n; ++v) {
        quality[v] = float(v) / 2;
        rgba[v] = {uint8_t(v % 256), 128, 0, 255};
    }
    MESHFLOW_TRY(mesh.set_quality(std::nullopt, quality));
    MESHFLOW_TRY(mesh.set_vertex_colors(std::nullopt, rgba));
    std::vector<uint32_t> first{0};
    MESHFLOW_TRY(mesh.set_vertex_colors(first, std::vector<std::array<uint8_t, 4>>{{1, 2, 3, 4}}));
    std::vector<int32_t> labels(mesh.triangle_slots(), -7);
    MESHFLOW_TRY(mesh.set_attribute(Domain::Face, "label", 1, std::nullopt, labels));
    MESHFLOW_TRY(mesh.set_attribute(Domain::Face, "scratch", 2, std::nullopt,
                                    std::vector<double>(2 * mesh.triangle_slots(), 0.5)));
    MESHFLOW_TRY(mesh.remove_attribute(Domain::Face, "scratch"));
    // A wrong shape is refused with the host's reason.
    auto wrong = mesh.set_attribute(Domain::Vertex, "quality", 2, std::nullopt, quality);
    if (wrong || wrong.error().kind != meshflow::ErrorKind::InvalidArgument)
        return meshflow::fail("a 2-component quality was accepted");

    std::string names;
    for (auto& a : mesh.attributes()) names += std::format("{}:{}x{},", a.name, a.components, int(a.type));
    auto back = mesh.quality();
    auto colours = mesh.vertex_colors();
    auto label = mesh.read_attribute(Domain::Face, "label");
    bool same = back && *back == quality && colours && (*colours)[0] == std::array<uint8_t, 4>{1, 2, 3, 4} &&
                (*colours)[1] == rgba[1] && label && std::get<std::vector<int32_t>>(*label) == labels;
    // Generic values read and written back unchanged.
    MESHFLOW_TRY(mesh.set_attribute(Domain::Face, "label", 1, std::nullopt, *label));
    return std::format("attributes={} same={} missing={}", names, int(same),
                       int(!mesh.read_attribute(Domain::Corner, "texcoord")));
}

// Lifts by `dz` every vertex of a proper triangle that is on no boundary edge, in one
// move-vertices. Run in blocks, a block's border is a boundary: the vertices blocks share stay.
Result<std::string> lift_inside(const Mesh& mesh, const Params& params) {
    float dz = float(params.get_real("dz"));
    meshflow::Array<float> xyz = mesh.positions();
    meshflow::Array<uint32_t> abc = mesh.triangles();
    meshflow::Array<uint8_t> kinds = mesh.half_edge_kinds();
    // Per vertex: 1 on a proper triangle, 2 on a boundary edge.
    std::vector<uint8_t> on(mesh.vertex_slots(), 0);
    for (size_t h = 0; h < kinds.size(); ++h) {
        if (kinds[h] == 0) continue;
        uint8_t mark = kinds[h] == 1 ? 2 : 1;
        for (uint32_t v : {abc[h], abc[h - h % 3 + (h + 1) % 3]}) on[v] = std::max(on[v], mark);
    }
    std::vector<uint32_t> ids;
    std::vector<float> lifted;
    for (uint32_t v = 0; v < on.size(); ++v) {
        if (on[v] != 1) continue;
        ids.push_back(v);
        lifted.insert(lifted.end(), {xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2] + dz});
    }
    MESHFLOW_TRY(mesh.move_vertices(ids, lifted));
    return std::format("lifted {} of {} vertices", ids.size(), on.size());
}

}  // namespace

std::vector<meshflow::Service> services() {
    using meshflow::Param;
    using meshflow::Service;
    // Builders on named objects.
    Param rounds = Param::integer("rounds", 3);
    rounds.range(1, 10);
    rounds.doc("Split and collapse rounds.");
    Service edit = Service::filter("sdk-api-edits", "Every mesh edit, once.", edits);
    edit.param(rounds);

    // The same filter run whole, and declared to run in blocks of `block-triangles` (0: whole).
    Service lift = Service::filter("sdk-api-lift", "Lifts what is off the boundary.", lift_inside)
                       .param(Param::real("dz", 0.01).range(-1, 1));
    Service in_blocks = lift;
    in_blocks.name = "sdk-api-lift-in-blocks";
    in_blocks.param(Param::integer("block-triangles", 1000).range(0, 4e9))
        .blocks([](const Params& p) { return uint32_t(p.get_integer("block-triangles")); });

    // A capturing lambda as a check, and a formatted failure.
    std::string unit = "triangles";
    auto fails = [unit](const Mesh& mesh, const Params&) -> Result<meshflow::Value> {
        return meshflow::fail("{} {} and a failure", mesh.triangle_count(), unit);
    };
    return {
        edit,
        Service::check("sdk-api-fail", "Fails, saying how many triangles.",
                       meshflow::ValueType::Text, fails),
        Service::filter("sdk-api-attributes", "Every attribute call.", attributes),
        Service::check("sdk-api-quality-in-check", "Writes quality in a check; the refusal.",
                       meshflow::ValueType::Text,
                       [](const Mesh& mesh, const Params&) -> Result<meshflow::Value> {
                           std::vector<float> q(mesh.vertex_slots(), 1.0f);
                           auto refused = mesh.set_quality(std::nullopt, q);
                           if (refused) return meshflow::fail("a check wrote quality");
                           return meshflow::Value{refused.error().message};
                       }),
        Service::filter("sdk-api-clear", "Removes everything.",
                        [](const Mesh& mesh, const Params&) -> Result<std::string> {
                            MESHFLOW_TRY(mesh.clear());
                            return std::format("{} left", mesh.triangle_count());
                        }),
        lift,
        in_blocks,
    };
}

MESHFLOW_EXPORT_PLUGIN(services)
