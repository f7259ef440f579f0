// Writes valid seed inputs for the blob fuzz targets: make_fuzz_seeds <corpus dir>.
#include "fuzz_fixture.h"

#include <cstdio>
#include <string>

static void write(const std::string& path, const std::vector<uint8_t>& bytes) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
}

int main(int argc, char** argv) {
    if (argc < 2) return 2;
    const std::string dir = argv[1];
    sdfuzz::Arm arm;
    int64_t n = 0;
    sd_rig_serialize(arm.rig, nullptr, 0, &n);
    std::vector<uint8_t> rig(static_cast<size_t>(n));
    sd_rig_serialize(arm.rig, rig.data(), n, &n);
    write(dir + "/fuzz_rig_blob/arm.bin", rig);
    sd_binding* b = arm.bind();
    sd_binding_serialize(b, nullptr, 0, &n);
    std::vector<uint8_t> bind(static_cast<size_t>(n));
    sd_binding_serialize(b, bind.data(), n, &n);
    write(dir + "/fuzz_binding_blob/arm.bin", bind);
    sd_binding_destroy(b);
    return 0;
}
