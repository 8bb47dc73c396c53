#version 450 core
// Lightmap pass, drawing: the relit lightmap sampled bilinearly at the
// lightmap UV (its gutters keep filtering off black). The lightmap's radiance
// holds the albedo at texel resolution; with u_detail the material's own
// albedo at this fragment (base colour factor x texture at the texture UV)
// replaces it: radiance x albedo(fragment) / albedo(texel), the texel albedo
// sampled from its own map the same way (where it is not ~0). Linear RGB.
// A lightmap of u_pages pages stacked in one texture (docs/LIGHTMAPS.md
// "Many pages") is filtered as each page alone: v clamped to the fragment's
// page, half a texel inside its edge (GL_CLAMP_TO_EDGE's rule), so a chart
// at a page's edge never reads the next page's row.
in vec2 v_uv_base;
in vec2 v_uv_lightmap;
layout(binding = 0) uniform sampler2D u_lightmap;
layout(binding = 1) uniform sampler2D u_texel_albedo;
layout(binding = 2) uniform sampler2D u_base;
layout(location = 4) uniform vec4 u_base_color;
layout(location = 5) uniform int u_has_texture;
layout(location = 6) uniform int u_detail;
layout(location = 7) uniform int u_pages;
layout(location = 0) out vec4 o_color;
void main() {
  vec2 uv = v_uv_lightmap;
  if (u_pages > 1) {
    const float rows = float(textureSize(u_lightmap, 0).y), page_rows = rows / float(u_pages);
    const float page = clamp(floor(uv.y * float(u_pages)), 0.0, float(u_pages - 1));
    uv.y = clamp(uv.y, (page * page_rows + 0.5) / rows, ((page + 1.0) * page_rows - 0.5) / rows);
  }
  vec3 b = texture(u_lightmap, uv).rgb;
  if (u_detail != 0) {
    vec3 albedo = u_base_color.rgb;
    if (u_has_texture != 0) albedo *= texture(u_base, v_uv_base).rgb;
    const vec3 texel = texture(u_texel_albedo, uv).rgb;
    for (int c = 0; c < 3; ++c)
      if (texel[c] > 1e-3) b[c] *= clamp(albedo[c], 0.0, 1.0) / texel[c];
  }
  o_color = vec4(b, 1.0);
}
