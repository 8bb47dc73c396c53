// The scene a lightmap was laid out in (prt/unwrap.h, lightmap_scene): the
// scene's own UV set, or the one prt made, made again.
#include <prt/unwrap.h>

#include <utility>

namespace prt {

UnwrapOptions lightmap_unwrap_options(int width, int height, int padding, int pages) {
  UnwrapOptions o;
  o.pages = pages;
  o.width = width;
  o.height = height;
  o.padding = padding;
  return o;
}

Scene lightmap_scene(Scene scene, const LightmapLayout& layout) {
  if (layout.unwrap_padding >= 0)
    scene = unwrap_scene(scene, lightmap_unwrap_options(layout.width, layout.page_height(), layout.unwrap_padding,
                                                        layout.pages));
  return stack_lightmap_pages(std::move(scene), layout.uv_set, layout.pages);
}

}  // namespace prt
