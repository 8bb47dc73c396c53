// tinygltf as the tests' glTF reader includes it (gltf_reader.cpp; the
// implementation in tinygltf_reader.cpp): no images decoded or loaded.
#pragma once

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
