// prt/web_export.h - the relighting web page of prt export --web and
// prt.export_web (docs/WEB.md): a static directory that relights the
// exported glTF in WebGL2 as prt render draws it.
#pragma once

#include <prt/mesh.h>
#include <prt/render.h>

#include <glm/vec4.hpp>

#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace prt {

struct WebPage {
  std::string dir;                // the directory to write
  bool force = false;             // replace an existing non-empty dir
  std::vector<std::string> maps;  // map files (the page's picker, in order)
  std::string initial;            // one of maps: shown first
  Camera camera;                  // the initial camera (eye, target, up, fov)
  double rotate[3] = {0, 0, 0};   // initial --rotate yaw,pitch,roll
  Display display;                // initial exposure and tone map
  // --exposure auto: the page measures its first frame (frame_exposure's
  // rule, web/prt-viewer.js) and display.exposure is only its fallback
  // (a browser that cannot read back a float target).
  bool auto_exposure = false;
  bool turn = false;              // start with the environment turning
  // A lightmap's page (model.glb from write_gltf_lightmap): the texels'
  // own albedo as an image (lightmap_image: gutters filled), which the
  // page divides out where a fragment takes its material's albedo, as
  // prt render does (Renderer::set_lightmap_detail). Empty for per-vertex
  // transfer. `lightmap_pages` pages of lightmap_width x lightmap_height
  // (a page's size), stacked top to bottom as lightmap_image gives them.
  std::vector<glm::vec4> lightmap_albedo;
  int lightmap_width = 0, lightmap_height = 0, lightmap_pages = 1;
  // prt export --three: the three.js page (docs/WEB.md "The three.js page"):
  // the same model.glb, lighting.json, lightmap_albedo.rgb16f and maps/,
  // with three.html as index.html, prt-three-page.js and prt-three.js in
  // place of prt-viewer.js. A lightmap's page only (lightmap_albedo set).
  bool three = false;
  // --three --probes: files beside the page's (probes.json, probes.bin),
  // written into the staged directory; lighting.json's "probes" names them.
  std::function<void(const std::string& dir)> write_probes;
};

// The HDR map files (.exr, .hdr, .pfm, any case) directly in `dir`,
// canonical and sorted; none when `dir` cannot be read. The maps prt view's
// N / P and the web page's picker offer.
std::set<std::filesystem::path> map_files_in(const std::filesystem::path& dir);

// The bundled maps (prt::data_dir()/envmaps: *.exr, *.hdr, *.pfm), sorted;
// with `env` not empty, that file too (first when not among them); `env`
// may also name a bundled map ("studio"). Returns the list; `initial` gets
// the entry that is `env` (or the first). Throws prt::Error naming --env.
std::vector<std::string> web_maps(const std::string& env, std::string& initial);

// Throws prt::Error naming `dir` when it exists and is not a directory, or
// is a non-empty directory and not `force`. Call it before the work.
void check_web_dir(const std::string& dir, bool force);

// A page written into a temporary sibling of its directory, not yet in
// place: commit() renames it to the directory (an existing one, allowed by
// --force, is moved aside first, then removed); the destructor removes what
// was not committed.
class StagedPage {
 public:
  ~StagedPage();
  StagedPage(const StagedPage&) = delete;
  StagedPage& operator=(const StagedPage&) = delete;
  void commit();  // throws prt::Error naming the directory

 private:
  friend std::unique_ptr<StagedPage> stage_web_page(const WebPage&, int,
                                                    const std::function<void(const std::string&)>&,
                                                    const std::function<bool()>&, bool);
  StagedPage(std::string dir, std::string tmp, std::string display)
      : dir_(std::move(dir)), tmp_(std::move(tmp)), display_(std::move(display)) {}
  std::string dir_, tmp_, display_;
};

// Writes the page, staged: index.html, prt-sh.js, prt-png.js, prt-viewer.js (embedded
// in prt; page.three: the three.js page's index.html, prt-three-page.js and prt-three.js instead), model.glb (write_model(path): the glTF writer), lighting.json
// (every map's SH coefficients at `bands`, the transfer's band count, the
// initial state), maps/NAME.rgb16f (each map as a lat-long background: RGB half
// floats, row 0 at the top) and maps/NAME.png (the picker's 128 x 64
// thumbnail) and, for a lightmap, lightmap_albedo.rgb16f (the texel albedo,
// RGB half floats, row 0 at the top; many pages one after another, lighting.json's
// "pages" beside a page's width and height). Checks the directory first (check_web_dir). Throws
// prt::Error("cancelled") when cancelled() turns true between maps (Ctrl-C),
// prt::Error naming the file on a bad map or a failed write; nothing is
// left then. Progress lines go to stderr unless quiet.
std::unique_ptr<StagedPage> stage_web_page(const WebPage& page, int bands,
                                           const std::function<void(const std::string& path)>& write_model,
                                           const std::function<bool()>& cancelled, bool quiet);

}  // namespace prt
