// Probe volume files (basis 3; docs/FORMAT.md "Probe volume"): the probe
// volume of prt/probes.h as a section family of the one transfer format
// (header, sections, checksum and atomic write of transfer_io_format.h).
// The format before it (signature "PRTP", a framing of its own) is refused
// by the signature check, naming it.
#include <prt/error.h>
#include <prt/probes.h>
#include <prt/transfer_io.h>

#include "transfer_io_format.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

namespace prt {

using namespace detail::tio;

namespace detail::tio {

// Header fields of a probe volume (the common ones at their usual offsets:
// bands, channels, mode, bounces; samples holds the rays per base texel,
// vertices the probe count and the mesh hash the scene's hash).
constexpr std::size_t kOffProbeCubeRes = 84;     // u32
constexpr std::size_t kOffProbeDepthRes = 88;    // u32
constexpr std::size_t kOffProbeBounceBands = 92; // u32
constexpr std::size_t kOffProbeDims = 96;        // i32[3]
constexpr std::size_t kOffProbeDepthCap = 108;   // f32
constexpr std::size_t kOffProbeReserved = 112;   // zero up to kHeaderSize

enum ProbeKind : std::uint32_t {
  kProbeGrid = 32,            // f64 x 6: the box, min x, y, z then max x, y, z
  kProbeStates = 33,          // u8 per probe (ProbeState)
  kProbePositions = 34,       // f32 x 3 per probe
  kProbeVisNodes = 35,        // u16, the stored probes' quadtree nodes
  kProbeVisOffsets = 36,      // u64, stored + 1
  kProbeVisComplement = 37,   // u8 per stored probe
  kProbePartialNodes = 38,    // u16
  kProbePartialMasks = 39,    // u16, one per partial texel
  kProbePartialOffsets = 40,  // u64, stored + 1
  kProbeDepth = 41,           // u16, 2 depth_res^2 per stored probe
  kProbeBounce = 42,          // f32, bounce_floats_per_probe() per stored probe (none when shadowed)
};
constexpr std::uint32_t kFirstProbeKind = kProbeGrid, kLastProbeKind = kProbeBounce;

struct ProbeSection {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
};
constexpr ProbeSection kProbeSections[] = {
    {kProbeGrid, "probe grid", kTypeF64},
    {kProbeStates, "probe states", kTypeU8},
    {kProbePositions, "probe positions", kTypeF32},
    {kProbeVisNodes, "visibility nodes", kTypeU16},
    {kProbeVisOffsets, "visibility node offsets", kTypeU64},
    {kProbeVisComplement, "visibility complement flags", kTypeU8},
    {kProbePartialNodes, "partial texels", kTypeU16},
    {kProbePartialMasks, "partial texel masks", kTypeU16},
    {kProbePartialOffsets, "partial texel offsets", kTypeU64},
    {kProbeDepth, "depth moments", kTypeU16},
    {kProbeBounce, "bounce matrices", kTypeF32},
};
constexpr std::size_t kProbeSectionCount = std::size(kProbeSections);

const ProbeSection& probe_section(std::uint32_t kind) { return kProbeSections[kind - kFirstProbeKind]; }

// The arrays of `t` as sections, in file order (the grid's box first).
std::vector<RawSection> probe_raw_sections(const ProbeTransfer& t, const double (&box)[6],
                                           const std::vector<std::uint8_t>& states) {
  const auto raw = [](std::uint32_t kind, std::uint64_t count, const void* data) {
    return RawSection{kind, probe_section(kind).type, count, count * type_bytes(probe_section(kind).type), data};
  };
  return {raw(kProbeGrid, 6, box),
          raw(kProbeStates, states.size(), states.data()),
          raw(kProbePositions, 3 * t.positions.size(), t.positions.data()),
          raw(kProbeVisNodes, t.vis_nodes.size(), t.vis_nodes.data()),
          raw(kProbeVisOffsets, t.vis_offsets.size(), t.vis_offsets.data()),
          raw(kProbeVisComplement, t.vis_complement.size(), t.vis_complement.data()),
          raw(kProbePartialNodes, t.partial_nodes.size(), t.partial_nodes.data()),
          raw(kProbePartialMasks, t.partial_mask.size(), t.partial_mask.data()),
          raw(kProbePartialOffsets, t.partial_offsets.size(), t.partial_offsets.data()),
          raw(kProbeDepth, t.depth.size(), t.depth.data()),
          raw(kProbeBounce, t.bounce.size(), t.bounce.data())};
}

void fill_probe_header(unsigned char (&h)[kHeaderSize], const ProbeTransfer& t) {
  TransferHeader v;  // the common fields' meaning for a probe volume (docs/FORMAT.md)
  v.bands = t.bands;
  v.channels = t.channels;
  v.mode = t.mode;
  v.bounces = t.bounces;
  v.samples = t.rays_per_texel;
  v.albedo = glm::vec3(0.0f);  // none: zero bytes
  v.seed = t.seed;
  v.vertices = t.probes();
  v.mesh_hash = t.scene_hash;
  fill_common_header(h, kProbeFormatVersion, kBasisProbes, v, 0u, kProbeSectionCount);
  store<std::uint32_t>(h + kOffProbeCubeRes, std::uint32_t(t.cube_res));
  store<std::uint32_t>(h + kOffProbeDepthRes, std::uint32_t(t.depth_res));
  store<std::uint32_t>(h + kOffProbeBounceBands, std::uint32_t(t.bounce_bands));
  for (int a = 0; a < 3; ++a) store<std::int32_t>(h + kOffProbeDims + 4 * std::size_t(a), t.grid.dims[std::size_t(a)]);
  store<float>(h + kOffProbeDepthCap, t.depth_cap);
}

}  // namespace detail::tio

std::vector<TransferSection> transfer_sections(const ProbeTransfer& t) {
  std::vector<TransferSection> out;
  const double box[6] = {};
  const std::vector<std::uint8_t> states(t.state.size());
  for (const RawSection& s : probe_raw_sections(t, box, states)) {
    const ProbeSection& p = probe_section(s.kind);
    out.push_back({s.kind, p.name, type_bytes(s.type), s.count, s.bytes, s.kind != kProbeGrid, type_name(s.type)});
  }
  return out;
}

std::uint64_t transfer_file_size(const ProbeTransfer& t) { return file_size_of(transfer_sections(t)); }

std::string describe_transfer(const ProbeTransfer& t) {
  std::size_t sky = 0, invalid = 0;
  for (ProbeState s : t.state) {
    sky += s == ProbeState::Sky;
    invalid += s == ProbeState::Invalid;
  }
  const double per = double(std::max<std::size_t>(t.stored(), 1));
  const glm::dvec3 sp = t.grid.spacing();
  std::string out = fmt::format("probe volume {}x{}x{} ({} probes: {} stored, {} see only sky, {} inside geometry)\n",
                                t.grid.dims[0], t.grid.dims[1], t.grid.dims[2], t.probes(), t.stored(), sky, invalid);
  out += fmt::format("  box ({:.4g}, {:.4g}, {:.4g}) to ({:.4g}, {:.4g}, {:.4g}), spacing {:.4g} x {:.4g} x {:.4g}\n",
                     t.grid.min.x, t.grid.min.y, t.grid.min.z, t.grid.max.x, t.grid.max.y, t.grid.max.z, sp.x, sp.y,
                     sp.z);
  out += fmt::format("  {} bands out, {}{}; visibility cube {}^2 a face ({} rays per base texel), depth moments {}^2\n",
                     t.bands, transfer_mode_name(t.mode),
                     t.mode == TransferMode::Interreflected
                         ? fmt::format(" ({} bounces, bounce matrices from {} bands, {} channel{})", t.bounces,
                                       t.bounce_bands, t.channels, t.channels == 1 ? "" : "s")
                         : std::string(),
                     t.cube_res, t.rays_per_texel, t.depth_res);
  out += fmt::format("  {} bytes, {:.0f} per stored probe ({:.1f} quadtree nodes, {:.1f} partial texels each); scene "
                     "hash {:#018x}\n",
                     t.bytes(), double(t.bytes()) / per, double(t.vis_nodes.size()) / per,
                     double(t.partial_nodes.size()) / per, t.scene_hash);
  return out;
}

void write_probe_transfer(const std::string& path, const ProbeTransfer& t) {
  if (const std::string p = probe_transfer_problem(t); !p.empty())
    throw Error(path + ": cannot write this probe volume: " + p);
  unsigned char header[kHeaderSize] = {};  // reserved bytes stay zero
  fill_probe_header(header, t);
  const double box[6] = {t.grid.min.x, t.grid.min.y, t.grid.min.z, t.grid.max.x, t.grid.max.y, t.grid.max.z};
  std::vector<std::uint8_t> states(t.state.size());
  for (std::size_t i = 0; i < states.size(); ++i) states[i] = std::uint8_t(t.state[i]);
  write_file(path, header, probe_raw_sections(t, box, states));
}

namespace detail::tio {

namespace {

// The header's values into `t`, each checked before anything is allocated.
void read_probe_header(const Reader& r, const unsigned char* h, std::uint64_t size, ProbeTransfer& t) {
  if (r.version() != kProbeFormatVersion)
    throw r.fail(fmt::format("bad header: format version {} for a probe volume (probe volumes are version {})",
                             r.version(), kProbeFormatVersion));
  const std::uint32_t mode = load<std::uint32_t>(h + kOffMode);
  if (mode != std::uint32_t(TransferMode::Shadowed) && mode != std::uint32_t(TransferMode::Interreflected))
    throw r.fail(fmt::format("bad header: mode {} (a probe volume is shadowed (1) or interreflected (2))", mode));
  if (load<std::uint32_t>(h + kOffFlags) != 0) throw r.fail("bad header: a probe volume has no flags");
  for (std::uint64_t i = kOffProbeReserved; i < kHeaderSize; ++i)
    if (h[i] != 0) throw r.fail(fmt::format("bad header: reserved byte {} is not zero", i));
  for (std::uint64_t i = kOffAlbedo; i < kOffFlags; ++i)
    if (h[i] != 0) throw r.fail(fmt::format("bad header: byte {} (an albedo, which a probe volume has not) is not zero", i));
  // Values narrowed to int are range-checked by probe_transfer_problem at the end.
  const auto narrow = [&](std::size_t off, const char* what) {
    const std::uint32_t x = load<std::uint32_t>(h + off);
    if (x > (1u << 24)) throw r.fail(fmt::format("bad header: {} is {}", what, x));
    return int(x);
  };
  t.bands = narrow(kOffBands, "bands");
  t.channels = narrow(kOffChannels, "channels");
  t.mode = TransferMode(mode);
  t.bounces = narrow(kOffBounces, "bounces");
  t.rays_per_texel = narrow(kOffSamples, "rays per texel");
  t.seed = load<std::uint64_t>(h + kOffSeed);
  t.scene_hash = load<std::uint64_t>(h + kOffMeshHash);
  t.cube_res = narrow(kOffProbeCubeRes, "cube resolution");
  t.depth_res = narrow(kOffProbeDepthRes, "depth resolution");
  t.bounce_bands = narrow(kOffProbeBounceBands, "bounce bands");
  for (std::size_t a = 0; a < 3; ++a) t.grid.dims[a] = load<std::int32_t>(h + kOffProbeDims + 4 * a);
  t.depth_cap = load<float>(h + kOffProbeDepthCap);
  if (const std::string p = probe_dims_problem(t.grid.dims); !p.empty()) throw r.fail("bad header: " + p);
  // A probe takes at least its state and position (13 bytes).
  if (load<std::uint64_t>(h + kOffVertices) != t.probes() || t.probes() > size / 13)
    throw r.fail(fmt::format("bad header: {} probes for a {}x{}x{} grid in a file of {} bytes",
                             load<std::uint64_t>(h + kOffVertices), t.grid.dims[0], t.grid.dims[1], t.grid.dims[2],
                             size));
  if (r.section_count() != kProbeSectionCount)
    throw r.fail(fmt::format("bad section table: {} sections; a probe volume has {}", r.section_count(),
                             kProbeSectionCount));
}

}  // namespace

ProbeTransfer Reader::read_probes() {
  open_file();
  read_head();
  verify();
  const std::uint32_t basis = load<std::uint32_t>(h_ + kOffBasis);
  if (basis != kBasisProbes)
    throw fail(basis <= kBasisZH ? "holds a per-point transfer, not a probe volume (prt precompute SCENE --probes "
                                   "NXxNYxNZ writes one)"
                                 : unknown_basis(basis));
  ProbeTransfer t;
  read_probe_header(*this, h_, size_, t);
  std::vector<double> box;
  std::vector<std::uint8_t> states;
  walk_sections(
      [&](const SectionHead& s) -> const char* {
        const std::uint32_t want = kFirstProbeKind + s.index;
        const ProbeSection& p = probe_section(want);
        if (s.kind != want)
          throw fail(fmt::format("bad section table: section {} has kind {}; expected {} ('{}')", s.index + 1, s.kind,
                                 want, p.name));
        if (s.type != p.type)
          throw fail(fmt::format("bad section table: section '{}' has element type {}; expected {} ({})", p.name,
                                 s.type, p.type, type_name(p.type)));
        const std::uint64_t probes = t.probes();
        const bool fixed = s.kind == kProbeGrid || s.kind == kProbeStates || s.kind == kProbePositions;
        const std::uint64_t want_count = s.kind == kProbeGrid ? 6 : s.kind == kProbeStates ? probes : 3 * probes;
        if (fixed && s.count != want_count)
          throw fail(fmt::format("bad section table: section '{}' has {} values; expected {}", p.name, s.count,
                                 want_count));
        if (s.kind == kProbePositions && s.count % 3 != 0)
          throw fail(fmt::format("bad section table: section '{}' has {} values, not triples", p.name, s.count));
        return p.name;
      },
      [&](const SectionHead& s) {
        switch (s.kind) {
          case kProbeGrid: read_section(s.data, box, s.count); break;
          case kProbeStates: read_section(s.data, states, s.count); break;
          case kProbePositions: read_section(s.data, t.positions, s.count / 3); break;
          case kProbeVisNodes: read_section(s.data, t.vis_nodes, s.count); break;
          case kProbeVisOffsets: read_section(s.data, t.vis_offsets, s.count); break;
          case kProbeVisComplement: read_section(s.data, t.vis_complement, s.count); break;
          case kProbePartialNodes: read_section(s.data, t.partial_nodes, s.count); break;
          case kProbePartialMasks: read_section(s.data, t.partial_mask, s.count); break;
          case kProbePartialOffsets: read_section(s.data, t.partial_offsets, s.count); break;
          case kProbeDepth: read_section(s.data, t.depth, s.count); break;
          case kProbeBounce: read_section(s.data, t.bounce, s.count); break;
        }
      });
  t.grid.min = {box[0], box[1], box[2]};
  t.grid.max = {box[3], box[4], box[5]};
  t.state.resize(states.size());
  for (std::size_t i = 0; i < states.size(); ++i) {
    if (states[i] > std::uint8_t(ProbeState::Invalid))
      throw fail(fmt::format("probe {} has an unknown state {}", i, states[i]));
    t.state[i] = ProbeState(states[i]);
  }
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw fail("inconsistent probe volume: " + p);
  return t;
}

}  // namespace detail::tio

ProbeTransfer read_probe_transfer(const std::string& path) { return Reader(path).read_probes(); }

}  // namespace prt
