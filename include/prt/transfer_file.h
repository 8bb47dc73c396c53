// prt/transfer_file.h - one type for a transfer file of any kind: one read,
// one write, and the one table of which consumer takes which kind.
//
// prt stores seven kinds of transfer, each a struct of its own beside its
// validator and its CPU relighting (prt/transfer.h, compressed_transfer.h,
// wavelet_transfer.h, zh_transfer.h, lightmap.h, probes.h). AnyTransfer is
// the closed set of them. A caller reads a file once (read_transfer_file),
// then dispatches once on what it holds:
//
//   prt::dispatch(any,
//       [&](const prt::Transfer& t) { ... },
//       [&](const prt::CompressedTransfer& c) { ... },
//       ...);                           // one lambda per kind, or `auto` for "the rest"
//
// A kind added to AnyTransfer is then a compile error at every dispatch that
// names the kinds one by one (no lambda takes it), never a fall-through to
// "SH" (docs/ARCHITECTURE.md, "Adding a transfer kind"). Consumers that take
// only some kinds refuse the others through support() below: one table, one
// sentence per refusal saying why and what to do.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/lightmap.h>
#include <prt/probes.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

namespace prt {

// The kinds, in the order of AnyTransfer's alternatives.
enum class TransferKind : std::uint8_t {
  SH = 0,               // Transfer: per-vertex SH vectors (and glossy matrices)
  Compressed = 1,       // CompressedTransfer: the same, rows by clustered PCA (prt compress)
  Wavelet = 2,          // WaveletTransfer: per-vertex Haar cube-map transfer (all-frequency)
  ZH = 3,               // ZhTransfer: per-vertex zonal-harmonic lobes that follow a deforming mesh
  Lightmap = 4,         // LightmapTransfer: SH transfer of a scene's lightmap texels
  WaveletLightmap = 5,  // WaveletLightmap: the wavelet transfer of the texels
  Probes = 6,           // ProbeTransfer: a probe volume over a scene
};

using AnyTransfer = std::variant<Transfer, CompressedTransfer, WaveletTransfer, ZhTransfer, LightmapTransfer,
                                 WaveletLightmap, ProbeTransfer>;
inline constexpr std::size_t kTransferKinds = std::variant_size_v<AnyTransfer>;

inline TransferKind kind_of(const AnyTransfer& t) { return TransferKind(t.index()); }

namespace detail {
// No kind derives from another: dispatch's lambda for the base would take the
// derived kind silently (a kind may hold another, as LightmapTransfer holds a
// Transfer, but not be one).
template <std::size_t... I>
constexpr bool kinds_unrelated(std::index_sequence<I...>) {
  constexpr auto derives = []<std::size_t J>(std::integral_constant<std::size_t, J>) {
    return ((J != I && std::is_base_of_v<std::variant_alternative_t<I, AnyTransfer>,
                                         std::variant_alternative_t<J, AnyTransfer>>) ||
            ...);
  };
  return !(derives(std::integral_constant<std::size_t, I>{}) || ...);
}
}  // namespace detail
static_assert(detail::kinds_unrelated(std::make_index_sequence<kTransferKinds>{}),
              "a transfer kind derives from another: dispatch() would hand it to the base's lambda");

// The kind of alternative T (a compile error for a type that is none).
template <typename T, std::size_t I = 0>
constexpr TransferKind kind_of_type() {
  static_assert(I < kTransferKinds, "not a transfer kind (an alternative of prt::AnyTransfer)");
  if constexpr (std::is_same_v<std::variant_alternative_t<I, AnyTransfer>, T>)
    return TransferKind(I);
  else
    return kind_of_type<T, I + 1>();
}

// How a kind is named: `id` in JSON and options ("sh", "compressed",
// "wavelet", "zh", "lightmap", "wavelet-lightmap", "probes"), `title` in
// sentences ("an SH transfer"), `made_by` the command that makes it.
struct KindNames {
  std::string_view id, title, made_by;
};
const KindNames& kind_names(TransferKind k);

// ---- dispatch ---------------------------------------------------------------------

template <typename... F>
struct Overloaded : F... {
  using F::operator()...;
};
template <typename... F>
Overloaded(F...) -> Overloaded<F...>;

// f(t) with t the kind's own struct, whatever `any` holds: one call per
// consumer. Every kind must be taken by one of `f` (a compile error
// otherwise).
template <typename Any, typename... F>
decltype(auto) dispatch(Any&& any, F&&... f) {
  return std::visit(Overloaded{std::forward<F>(f)...}, std::forward<Any>(any));
}

// ---- files ----------------------------------------------------------------------

// Reads any prt transfer file (docs/FORMAT.md), validating everything as the
// kind's own reader does; throws prt::Error "PATH: problem". A probe volume
// of the format before the shared framing ("PRTP") is refused with "made by
// an older prt: precompute it again". *version (when given): the file's
// format version (an SH file may be older than what prt writes today).
AnyTransfer read_transfer_file(const std::string& path, std::uint32_t* version = nullptr);
// Writes `t` with its kind's writer (atomically; the kind's validator first).
void write_transfer_file(const std::string& path, const AnyTransfer& t);
// The multi-line summary of prt info (each kind's describe_transfer). Named
// apart from the kinds' overloads so that a kind without one is a compile
// error, not a call of this through AnyTransfer's converting constructor.
std::string describe(const AnyTransfer& t);
// The exact size of the file write_transfer_file writes for `t` (each kind's
// transfer_file_size).
std::uint64_t file_size(const AnyTransfer& t);

// The kind's own typed reader: reads any file, and refuses one of another
// kind with "PATH: holds TITLE (MADE_BY), not TITLE_OF_T".
template <typename T>
T read_transfer_as(const std::string& path);

// ---- which consumer takes which kind ------------------------------------------------

// Everything that takes a transfer file (or makes one: mpirun, --memory-limit).
enum class Consumer : std::uint8_t {
  Info,          // prt info, prt.info
  Relight,       // prt relight
  Render,        // prt render
  View,          // prt view
  ExportGlb,     // prt export -o FILE.glb
  ExportBake,    // prt export --bake ENV
  ExportWeb,     // prt export --web DIR
  Compress,      // prt compress
  Reference,     // prt reference (the Monte Carlo truth of the kind's radiance) and prt compare
  PythonRead,    // prt.read_transfer
  PythonRelight, // <object>.relight
  PythonRender,  // prt.render
  PythonExport,  // prt.export_gltf, prt.export_web
  Mpi,           // mpirun -np N prt precompute
  MemoryLimit,   // prt precompute --memory-limit
  GpuPrecompute, // prt precompute --device gpu (the kind made on the GPU)
};
inline constexpr std::size_t kConsumers = 16;

// Whether `consumer` takes `kind`; when it does not, `why` is the sentence
// the refusal says (why, and what to do instead), and when it does, how (the
// command or function).
struct Support {
  bool works = false;
  std::string_view why;
};
const Support& support(TransferKind kind, Consumer consumer);
std::string_view consumer_name(Consumer c);  // "prt info", "prt relight", ...

// Throws prt::Error "PATH: <why>" unless `consumer` takes the kind of `t`.
void require_support(TransferKind kind, Consumer consumer, const std::string& path);

// The table as GitHub Markdown (kinds as rows, consumers as columns, "yes"
// or "no (footnote n)" with the sentences below): docs/ARCHITECTURE.md shows
// it, and a test keeps the two the same.
std::string support_table_markdown();

// ---- implementation ------------------------------------------------------------------

namespace detail {
[[noreturn]] void refuse_kind(const std::string& path, TransferKind held, TransferKind wanted);
}  // namespace detail

template <typename T>
T read_transfer_as(const std::string& path) {
  AnyTransfer any = read_transfer_file(path);
  if (T* t = std::get_if<T>(&any)) return std::move(*t);
  detail::refuse_kind(path, kind_of(any), kind_of_type<T>());
}

}  // namespace prt
