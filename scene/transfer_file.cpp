// One type for a transfer file of any kind (prt/transfer_file.h): the kinds'
// names, the one read and write, and the table of which consumer takes which.
#include <prt/transfer_file.h>

#include <prt/error.h>
#include <prt/transfer_io.h>

#include "transfer_io_format.h"

#include <fmt/format.h>

#include <array>
#include <string>

namespace prt {

namespace {

using S = Support;

// One row per kind: its names, then one entry per consumer (Consumer's
// order). An entry that works says how; one that does not says why and
// what to do, as the refusal's sentence. A row with fewer entries than
// consumers, or a kind without a row, fails the static_asserts below.
struct KindRow {
  TransferKind kind;
  KindNames names;
  std::array<Support, kConsumers> support;
};

constexpr std::array<KindRow, kTransferKinds> kRows = {{
    {TransferKind::SH,
     {"sh", "an SH transfer", "prt precompute MESH"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight MESH FILE ENV -o OUT.ply|csv"},
       S{true, "prt render MESH FILE ENV -o OUT.png"},
       S{true, "prt view MESH FILE ENV"},
       S{true, "prt export MESH FILE -o OUT.glb (glossy matrices stay out: glTF carries the diffuse rows)"},
       S{true, "prt export MESH FILE -o OUT.glb --bake ENV"},
       S{true, "prt export MESH FILE --web DIR"},
       S{true, "prt compress FILE -o OUT.prt"},
       S{true, "prt reference MESH ENV (--material glossy for the lobe)"},
       S{true, "prt.read_transfer(FILE): a Transfer"},
       S{true, "Transfer.relight"},
       S{true, "prt.render"},
       S{true, "prt.export_gltf, prt.export_web"},
       S{true, "mpirun -np N prt precompute MESH ..."},
       S{true, "prt precompute MESH --memory-limit SIZE"},
       S{true, "prt precompute MESH --device gpu (shadowed, interreflected, glossy)"}}}},
    {TransferKind::Compressed,
     {"compressed", "a compressed SH transfer", "prt compress"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight MESH FILE ENV -o OUT.ply|csv (per-cluster products)"},
       S{true, "prt render MESH FILE ENV -o OUT.png (--shading clusters shows them)"},
       S{true, "prt view MESH FILE ENV"},
       S{true, "prt export MESH FILE -o OUT.glb (rows rebuilt from the clusters)"},
       S{true, "prt export MESH FILE -o OUT.glb --bake ENV"},
       S{true, "prt export MESH FILE --web DIR"},
       S{false, "is already compressed by clustered PCA; compress the file prt precompute wrote instead (prt "
                "compress IN.prt -o OUT.prt, with other -k/-n or --target-error)"},
       S{true, "prt reference MESH ENV (the truth the compressed rows approximate)"},
       S{true, "prt.read_transfer(FILE): a Transfer holding its compressed form"},
       S{true, "Transfer.relight (per-cluster products)"},
       S{true, "prt.render"},
       S{true, "prt.export_gltf, prt.export_web (rows rebuilt)"},
       S{true, "mpirun -np N prt precompute MESH --compress KxN"},
       S{true, "prt precompute MESH --compress KxN --memory-limit SIZE"},
       S{true, "prt precompute MESH --compress KxN --device gpu (the rays on the GPU, clustered PCA on the CPU)"}}}},
    {TransferKind::Wavelet,
     {"wavelet", "a wavelet transfer", "prt precompute MESH --basis wavelet"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight MESH FILE ENV -o OUT.ply|csv --terms K"},
       S{true, "prt render MESH FILE ENV -o OUT.png --terms K"},
       S{true, "prt view MESH FILE ENV (--second SH.prt: B switches)"},
       S{false, "is a wavelet transfer, whose sparse Haar rows no glTF viewer reads: export an SH transfer of the "
                "mesh (prt precompute MESH --basis sh), or bake this one's colours with prt relight -o OUT.ply"},
       S{false, "is a wavelet transfer: prt export bakes SH transfers; relight this one into vertex colours with prt "
                "relight MESH FILE ENV -o OUT.ply (--tonemap clamp --srgb for 8-bit colours)"},
       S{false, "is a wavelet transfer: the web page relights SH rows in WebGL2; export an SH transfer of the mesh "
                "(prt precompute MESH --basis sh)"},
       S{false, "is a wavelet transfer, already sparse and quantised (prt precompute --threshold sets its size); prt "
                "compress compresses SH transfers"},
       S{true, "prt reference MESH ENV"},
       S{true, "prt.read_transfer(FILE): a WaveletTransfer"},
       S{true, "WaveletTransfer.relight"},
       S{true, "prt.render"},
       S{false, "is a wavelet transfer: prt.export_gltf and prt.export_web take SH transfers (prt.precompute)"},
       S{true, "mpirun -np N prt precompute MESH --basis wavelet"},
       S{false, "--memory-limit plans an SH transfer's memory; a wavelet transfer's size is set by --cube-res and "
                "--threshold: leave --memory-limit out"},
       S{true, "prt precompute MESH --basis wavelet --device gpu (each cube texel's ray)"}}}},
    {TransferKind::ZH,
     {"zh", "a zonal-harmonic (local deformable) transfer", "prt precompute MESH --basis zh"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight POSED FILE ENV -o OUT.ply|csv (--deform, --time, --dynamic-ao)"},
       S{true, "prt render MESH FILE ENV -o OUT.png (--deform, a glTF skin's --time)"},
       S{true, "prt view MESH FILE ENV (a skinned glTF animates)"},
       S{false, "is a zonal-harmonic transfer, whose lobes turn with a deforming mesh: glTF carries SH rows of one "
                "pose; export an SH transfer (prt precompute MESH --basis sh), or relight a pose with prt relight"},
       S{false, "is a zonal-harmonic transfer: prt export bakes SH transfers; relight a pose into vertex colours with "
                "prt relight POSED FILE ENV -o OUT.ply"},
       S{false, "is a zonal-harmonic transfer: the web page relights SH rows of a still mesh; export an SH transfer "
                "(prt precompute MESH --basis sh)"},
       S{false, "is a zonal-harmonic transfer, a few lobes per vertex already; prt compress compresses SH transfers"},
       S{true, "prt reference POSED ENV (the truth of a pose)"},
       S{true, "prt.read_transfer(FILE): a ZhTransfer"},
       S{true, "ZhTransfer.relight"},
       S{true, "prt.render"},
       S{false, "is a zonal-harmonic transfer: prt.export_gltf and prt.export_web take SH transfers (prt.precompute)"},
       S{true, "mpirun -np N prt precompute MESH --basis zh"},
       S{true, "prt precompute MESH --basis zh --memory-limit SIZE"},
       S{true, "prt precompute MESH --basis zh --device gpu (the SH transfer on the GPU, the lobes fitted on the CPU)"}}}},
    {TransferKind::Lightmap,
     {"lightmap", "an SH lightmap", "prt precompute SCENE --lightmap WxH"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight SCENE FILE ENV -o OUT.exr (the atlas)"},
       S{true, "prt render SCENE FILE ENV -o OUT.png"},
       S{true, "prt view SCENE FILE ENV"},
       S{true, "prt export SCENE FILE -o OUT.glb (coefficient textures)"},
       S{true, "prt export SCENE FILE -o OUT.glb --bake ENV"},
       S{true, "prt export SCENE FILE --web DIR"},
       S{false, "is a lightmap: clustered PCA compresses per-vertex SH transfers; a lightmap's size is set by WxH "
                "(prt precompute --lightmap)"},
       S{true, "prt reference SCENE ENV --lightmap WxH"},
       S{true, "prt.read_transfer(FILE): a Lightmap"},
       S{true, "Lightmap.relight"},
       S{true, "prt.render"},
       S{true, "prt.export_gltf(lightmap, scene, PATH), prt.export_web(lightmap, scene, DIR)"},
       S{true, "mpirun -np N prt precompute SCENE --lightmap WxH"},
       S{true, "prt precompute SCENE --lightmap WxH --memory-limit SIZE"},
       S{true, "prt precompute SCENE --lightmap WxH --device gpu (--directional too)"}}}},
    {TransferKind::WaveletLightmap,
     {"wavelet-lightmap", "a wavelet lightmap", "prt precompute SCENE --lightmap WxH --basis wavelet"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight SCENE FILE ENV -o OUT.exr --terms K (the atlas)"},
       S{false, "is a wavelet lightmap, which the GPU renderer does not draw (its rows are relit on the CPU): relight "
                "it into an atlas with prt relight SCENE FILE ENV -o OUT.exr, or render an SH lightmap (prt "
                "precompute SCENE --lightmap WxH)"},
       S{false, "is a wavelet lightmap, which the GPU renderer does not draw: view an SH lightmap of the scene (prt "
                "precompute SCENE --lightmap WxH)"},
       S{false, "is a wavelet lightmap: glTF carries SH coefficient textures; export an SH lightmap (prt precompute "
                "SCENE --lightmap WxH)"},
       S{false, "is a wavelet lightmap: prt export bakes SH lightmaps; relight this one into an atlas with prt relight "
                "SCENE FILE ENV -o OUT.exr"},
       S{false, "is a wavelet lightmap: the web page relights SH coefficient textures; export an SH lightmap (prt "
                "precompute SCENE --lightmap WxH, then prt export SCENE FILE --web DIR)"},
       S{false, "is a wavelet lightmap, already sparse and quantised; prt compress compresses SH transfers"},
       S{true, "prt reference SCENE ENV --lightmap WxH"},
       S{false, "is a wavelet lightmap, which Python does not read yet: relight it with prt relight SCENE FILE ENV -o "
                "OUT.exr, or make an SH lightmap with prt.precompute_lightmap"},
       S{false, "is a wavelet lightmap, which Python does not read yet: prt relight SCENE FILE ENV -o OUT.exr"},
       S{false, "is a wavelet lightmap, which Python does not read yet (and the GPU renderer does not draw): relight "
                "it with prt relight SCENE FILE ENV -o OUT.exr"},
       S{false, "is a wavelet lightmap, which Python does not read yet: export an SH lightmap of the scene (prt "
                "precompute SCENE --lightmap WxH, then prt export)"},
       S{true, "mpirun -np N prt precompute SCENE --lightmap WxH --basis wavelet"},
       S{false, "--memory-limit plans an SH transfer's memory; a wavelet lightmap's size is set by WxH, --cube-res "
                "and --threshold: leave --memory-limit out"},
       S{true, "prt precompute SCENE --lightmap WxH --basis wavelet --device gpu"}}}},
    {TransferKind::Probes,
     {"probes", "a probe volume", "prt precompute SCENE --probes NXxNYxNZ"},
     {{S{true, "prt info FILE"},
       S{true, "prt relight SCENE FILE ENV --at POINTS.csv -o OUT.csv (E/pi at the points)"},
       S{false, "is a probe volume, which lights objects moving through the scene, not the scene's surfaces: render "
                "the scene's lightmap and give the volume as --probes FILE with --object MESH"},
       S{false, "is a probe volume, which lights objects moving through the scene: view the scene's lightmap with "
                "--probes FILE --object MESH"},
       S{false, "is a probe volume: glTF carries a mesh's transfer; prt export SCENE --probes FILE --bake ENV -o "
                "OUT.json writes its probes' SH for three.js and Unity"},
       S{false, "is a probe volume: prt export SCENE --probes FILE --bake ENV -o OUT.json writes its probes' SH "
                "(three.js LightProbe, Unity SphericalHarmonicsL2)"},
       S{false, "is a probe volume: the web page relights a mesh's transfer; prt export SCENE --probes FILE --bake ENV "
                "-o OUT.json writes its probes' SH for three.js"},
       S{false, "is a probe volume, whose visibility is a quadtree already; prt compress compresses SH transfers"},
       S{true, "prt reference SCENE ENV --at POINTS.csv"},
       S{true, "prt.read_transfer(FILE): a ProbeVolume"},
       S{true, "ProbeVolume.relight"},
       S{true, "prt.render(..., probes=FILE, object=MESH)"},
       S{true, "prt.export_probes"},
       S{false, "a probe volume is traced in one process (not under mpirun) for now: run prt precompute SCENE "
                "--probes without mpirun"},
       S{false, "--memory-limit plans an SH transfer's memory; a probe volume has no such plan (a 64x32x64 volume "
                "takes about 80 MB; docs/PROBES.md): leave --memory-limit out"},
       S{true, "prt precompute SCENE --probes NXxNYxNZ --device gpu (each wavefront of rays)"}}}},
}};

constexpr bool rows_complete() {
  for (std::size_t k = 0; k < kTransferKinds; ++k) {
    if (kRows[k].kind != TransferKind(k) || kRows[k].names.id.empty()) return false;
    for (const Support& s : kRows[k].support)
      if (s.why.empty()) return false;
  }
  return true;
}
static_assert(rows_complete(), "every kind needs its row, in TransferKind's order, and every entry its sentence");

constexpr std::array<std::string_view, kConsumers> kConsumerNames = {
    "prt info",          "prt relight", "prt render",     "prt view",       "prt export (.glb)",
    "prt export --bake", "prt export --web", "prt compress", "prt reference", "prt.read_transfer",
    "Python relight",    "prt.render",  "Python export",  "mpirun",         "--memory-limit",
    "--device gpu",
};

}  // namespace

const KindNames& kind_names(TransferKind k) { return kRows[std::size_t(k)].names; }

const Support& support(TransferKind kind, Consumer consumer) {
  return kRows[std::size_t(kind)].support[std::size_t(consumer)];
}

std::string_view consumer_name(Consumer c) { return kConsumerNames[std::size_t(c)]; }

void require_support(TransferKind kind, Consumer consumer, const std::string& path) {
  const Support& s = support(kind, consumer);
  if (!s.works) throw Error(fmt::format("{}: {}", path, s.why));
}

std::string support_table_markdown() {
  std::string out = "| kind |";
  for (std::size_t c = 0; c < kConsumers; ++c) out += fmt::format(" {} |", kConsumerNames[c]);
  out += "\n|---|";
  for (std::size_t c = 0; c < kConsumers; ++c) out += "---|";
  out += "\n";
  std::vector<std::string> notes;
  for (const KindRow& r : kRows) {
    out += fmt::format("| {} |", r.names.id);
    for (std::size_t c = 0; c < kConsumers; ++c) {
      const Support& s = r.support[c];
      if (s.works) {
        out += " yes |";
      } else {
        notes.push_back(fmt::format("{} x {}: \"FILE: {}\"", r.names.id, kConsumerNames[c], s.why));
        out += fmt::format(" no ({}) |", notes.size());
      }
    }
    out += "\n";
  }
  out += "\n";
  for (std::size_t i = 0; i < notes.size(); ++i) out += fmt::format("{}. {}\n", i + 1, notes[i]);
  return out;
}

namespace detail {

void refuse_kind(const std::string& path, TransferKind held, TransferKind wanted) {
  const KindNames& h = kind_names(held);
  throw Error(fmt::format("{}: holds {} ({}), not {} ({}); prt::read_transfer_file reads any kind", path, h.title,
                          h.made_by, kind_names(wanted).title, kind_names(wanted).made_by));
}

}  // namespace detail

// ---- files ----------------------------------------------------------------------------

AnyTransfer read_transfer_file(const std::string& path, std::uint32_t* version) {
  // The header says which kind; the kind's reader then checks everything.
  detail::tio::Reader r(path);
  const std::uint32_t basis = r.read_basis();
  const std::uint32_t flags = r.flags();
  if (version) *version = r.version();
  using namespace detail::tio;
  const bool lightmap = (flags & kFlagLightmap) != 0;
  switch (basis) {
    case kBasisWavelet:
      if (lightmap) return read_wavelet_lightmap(path);
      return read_wavelet_transfer(path);
    case kBasisZH: return read_zh_transfer(path);
    case kBasisProbes: return read_probe_transfer(path);
    default: break;
  }
  // SH: version 4 introduced compression, 5 lightmaps; an older file's flag
  // bits are refused by the SH reader itself.
  if (r.version() >= 5 && lightmap) return read_lightmap_transfer(path);
  if (r.version() >= 4 && (flags & kFlagCompressed) != 0) return read_compressed_transfer(path);
  return read_transfer(path);
}

void write_transfer_file(const std::string& path, const AnyTransfer& t) {
  dispatch(
      t, [&](const Transfer& x) { write_transfer(path, x); },
      [&](const CompressedTransfer& x) { write_compressed_transfer(path, x); },
      [&](const WaveletTransfer& x) { write_wavelet_transfer(path, x); },
      [&](const ZhTransfer& x) { write_zh_transfer(path, x); },
      [&](const LightmapTransfer& x) { write_lightmap_transfer(path, x); },
      [&](const WaveletLightmap& x) { write_wavelet_lightmap(path, x); },
      [&](const ProbeTransfer& x) { write_probe_transfer(path, x); });
}

std::string describe(const AnyTransfer& t) {
  return dispatch(t, [](const auto& x) { return describe_transfer(x); });
}

std::uint64_t file_size(const AnyTransfer& t) {
  return dispatch(t, [](const auto& x) { return transfer_file_size(x); });
}

}  // namespace prt
