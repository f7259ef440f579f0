// The glTF reader (sweepdeform_io::load_gltf_character, TinyGLTF underneath; the command-line
// tool's and the native tests' way to load a character): arbitrary bytes, a .glb or a .gltf
// with embedded buffers, either load into a character that validate() accepts and whose every
// animation can be sampled, or throw std::exception; nothing else. The first byte picks the
// options (bit 0: weld, bit 1: keep glTF's Y-up axes). Loading from memory never opens a file
// named in the input. Accessors claiming billions of elements must be refused before
// allocating (ASan's allocator limit would report them).
#include <sweepdeform_io/animation.h>
#include <sweepdeform_io/character.h>
#include <sweepdeform_io/gltf_loader.h>

#include <cstdint>
#include <exception>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    sd::io::GltfLoadOptions options;
    options.weld = (data[0] & 1) != 0;
    options.to_blender_axes = (data[0] & 2) == 0;
    try {
        const sd::io::Character c = sd::io::load_gltf_character_from_memory(data + 1, size - 1, "fuzz.glb", options);
        if (!sd::io::validate(c).empty()) __builtin_trap();  // the loader promises a valid character
        const size_t B = c.bone_names.size();
        if (sd::io::sample_pose(c, -1, 0.0).size() != 16 * B) __builtin_trap();
        for (size_t a = 0; a < c.animations.size() && a < 4; ++a) {
            const sd::io::Animation& anim = c.animations[a];
            for (double t : {anim.first_key_s - 1.0, anim.first_key_s, 0.5 * (anim.first_key_s + anim.duration_s),
                             anim.duration_s, anim.duration_s + 1.0})
                if (sd::io::sample_pose(c, static_cast<int>(a), t).size() != 16 * B) __builtin_trap();
        }
    } catch (const std::exception&) {}
    return 0;
}
