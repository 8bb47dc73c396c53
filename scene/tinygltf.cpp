// tinygltf's implementation (Debian's libtinygltf-dev, header only), compiled
// once for prt::scene, renamed and hidden as gltf_model.h declares it for the
// units that use it (gltf.cpp, gltf_lightmap.cpp, scene.cpp, skin.cpp).
//
// A file of its own, outside the unity batches, so that the sanitizer build
// can compile it uninstrumented (scene/CMakeLists.txt): it is a dependency's
// code, like the Debian libraries prt links, and instrumenting it (with the
// nlohmann::json it parses with) cost about 30 s of that build's compile
// time on CI's 2 cores (49 s against 19 s for this one unit).
#define TINYGLTF_IMPLEMENTATION
#include "gltf_model.h"
