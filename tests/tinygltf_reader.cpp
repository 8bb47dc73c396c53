// tinygltf's implementation for the tests' glTF reader (gltf_reader.cpp): a
// file of its own, which the sanitizer build compiles uninstrumented
// (prt_dependency_sources, CMakeLists.txt).
#define TINYGLTF_IMPLEMENTATION
#include "tinygltf_reader.h"
