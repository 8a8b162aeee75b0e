// Runs edits.cpp's services natively and prints, per service, the kind and message of its
// refusal (or a check's value), which tests/cpp_native.rs compares with a host's.
#include <meshflow.hpp>

#include <cstdio>

using meshflow::ErrorKind;

int main(int argc, char** argv) {
    if (argc < 2) return 2;
    auto mesh = meshflow::native::load(argv[1]);
    if (!mesh) return std::fprintf(stderr, "%s\n", mesh.error().message.c_str()), 1;
    int failures = 0;
    const std::pair<const char*, ErrorKind> refused[] = {
        {"repeat-corner", ErrorKind::RepeatedVertex},
        {"move-removed", ErrorKind::InvalidVertex},
        {"clear-in-check", ErrorKind::ReadOnly},
        {"bad-attribute-shape", ErrorKind::InvalidArgument},
        {"quality-in-check", ErrorKind::ReadOnly}};
    for (auto [service, kind] : refused) {
        auto out = meshflow::native::run(service, *mesh);
        if (out) {
            std::fprintf(stderr, "FAILED: %s was not refused\n", service);
            ++failures;
            continue;
        }
        if (out.error().kind != kind) {
            std::fprintf(stderr, "FAILED: %s refused as %s\n", service,
                         std::string(meshflow::to_string(out.error().kind)).c_str());
            ++failures;
        }
        std::printf("%s\t%s\t%s\n", service, std::string(meshflow::to_string(out.error().kind)).c_str(),
                    out.error().message.c_str());
    }
    auto check = meshflow::native::run("edit-in-check", *mesh);
    if (!check || !check->value || check->ops.size() != 0 || check->mesh.hash() != mesh->hash()) {
        std::fprintf(stderr, "FAILED: edit-in-check\n");
        ++failures;
    } else {
        std::printf("edit-in-check\tvalue\t%s\n", std::get<std::string>(*check->value).c_str());
    }
    auto written = meshflow::native::run("write-attributes", *mesh);
    if (!written || written->report != "2 attributes") {
        std::fprintf(stderr, "FAILED: write-attributes\n");
        ++failures;
    } else {
        std::printf("write-attributes\thash\t%s\n", written->mesh.hash().c_str());
    }
    return failures ? 1 : 0;
}
