// The GLSL sources of shaders/, embedded at build time (runtime/embed_shaders.cmake).
#pragma once

namespace prt::shaders {
extern const char* const relight_comp_glsl;
extern const char* const glossy_comp_glsl;
extern const char* const compressed_glsl;  // inserted after the #defines of a compressed program
extern const char* const mesh_frag_glsl;
extern const char* const background_vert_glsl;
extern const char* const background_frag_glsl;
extern const char* const attribute_vert_glsl;
extern const char* const display_frag_glsl;
extern const char* const lightmap_comp_glsl;
extern const char* const lightmap_vert_glsl;
extern const char* const lightmap_frag_glsl;
extern const char* const probe_object_comp_glsl;
extern const char* const sh_bands_glsl;  // the lighting block before sh_glsl.h's sh_band_sums
extern const char* const zh_comp_glsl;
extern const char* const shadow_vert_glsl;
extern const char* const shadow_frag_glsl;
extern const char* const lights_comp_glsl;
extern const char* const bounce_comp_glsl;
}  // namespace prt::shaders
