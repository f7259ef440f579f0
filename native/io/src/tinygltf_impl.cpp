// The one translation unit that compiles TinyGLTF's implementation (header-only library).
// TINYGLTF_NO_STB_IMAGE, TINYGLTF_NO_STB_IMAGE_WRITE and TINYGLTF_NO_EXTERNAL_IMAGE are set
// for the whole target in CMakeLists.txt: they change TinyGLTF's class definitions, so every
// file including tiny_gltf.h must see the same values. Images are never decoded (we only need
// geometry, skin and animation); gltf_loader.cpp installs a no-op image callback.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
