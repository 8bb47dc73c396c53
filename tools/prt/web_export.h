// The relighting web page of prt export --web (docs/WEB.md): a static
// directory that relights the exported glTF in WebGL2 as prt render draws it.
#pragma once

#include <prt/mesh.h>
#include <prt/render.h>
#include <prt/transfer.h>

#include <functional>
#include <string>
#include <vector>

namespace prt::cli {

struct WebPage {
  std::string dir;                // the directory to write
  bool force = false;             // replace an existing non-empty dir
  std::vector<std::string> maps;  // map files (the page's picker, in order)
  std::string initial;            // one of maps: shown first
  Camera camera;                  // the initial camera (eye, target, up, fov)
  double rotate[3] = {0, 0, 0};   // initial --rotate yaw,pitch,roll
  Display display;                // initial exposure and tone map
  bool turn = false;              // start with the environment turning
};

// The bundled maps (prt::data_dir()/envmaps: *.exr, *.hdr, *.pfm), sorted;
// with `env` not empty, that file too (first when not among them); `env`
// may also name a bundled map ("studio"). Returns the list; `initial` gets
// the entry that is `env` (or the first). Throws prt::Error naming --env.
std::vector<std::string> web_maps(const std::string& env, std::string& initial);

// Writes the page: index.html, prt-sh.js, prt-viewer.js (embedded in prt),
// model.glb (write_model(path): the glTF writer), lighting.json (every map's
// SH coefficients at the transfer's band count, the initial state) and
// maps/NAME.rgb16f (each map as a lat-long background: RGB half floats, row
// 0 at the top) and maps/NAME.png (the picker's 128 x 64 thumbnail). Everything goes into a temporary sibling directory renamed
// to page.dir at the end; an existing page.dir that is not an empty
// directory is refused (prt::Error naming it) unless page.force, when it is
// replaced. Progress lines go to stderr unless quiet.
void write_web_page(const WebPage& page, const Transfer& transfer,
                    const std::function<void(const std::string& path)>& write_model, bool quiet);

}  // namespace prt::cli
