// The scene a lightmap was laid out in (prt/unwrap.h, lightmap_scene): the
// scene's own UV set, or the one prt made, made again.
#include <prt/unwrap.h>

#include <utility>

namespace prt {

Scene lightmap_scene(Scene scene, const LightmapLayout& layout) {
  if (layout.unwrap_padding < 0) return scene;
  UnwrapOptions o;
  o.width = layout.width;
  o.height = layout.height;
  o.padding = layout.unwrap_padding;
  return unwrap_scene(scene, o);
}

}  // namespace prt
