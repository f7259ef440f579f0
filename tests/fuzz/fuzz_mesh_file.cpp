// The OBJ / PLY / OFF / XYZ reader (sweepdeform_io::read_mesh, OpenMesh underneath): arbitrary
// bytes in a file of the extension the first byte picks either read into finite positions and
// triangles indexing them, or throw std::exception. Headers claiming billions of elements
// must be refused before allocating (ASan's allocator limit would report them).
#include <sweepdeform_io/mesh_io.h>

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    static const char* kExt[] = {".obj", ".ply", ".off", ".xyz"};
    const std::string path = "/tmp/sweepdeform_fuzz_mesh_" + std::to_string(::getpid()) + kExt[data[0] % 4];
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
    try {
        int dropped = 0;
        const sd::io::MeshData m = sd::io::read_mesh(path, &dropped);
        const size_t V = m.positions.size() / 3;
        for (float x : m.positions)
            if (!std::isfinite(x)) __builtin_trap();
        for (int32_t t : m.triangles)
            if (t < 0 || static_cast<size_t>(t) >= V) __builtin_trap();
        if (dropped < 0) __builtin_trap();
    } catch (const std::exception&) {}
    std::remove(path.c_str());
    return 0;
}
