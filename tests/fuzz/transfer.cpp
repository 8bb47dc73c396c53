// Fuzz target: the transfer file reader (docs/FORMAT.md), every kind:
// read_transfer_file (prt/transfer_file.h), then through dispatch, what each
// kind's consumers ask of what was read (describe_transfer, transfer_sections;
// an SH transfer's byte counts, a compressed one decompressed), and each
// kind's own reader (read_transfer, read_compressed_transfer,
// read_wavelet_transfer, read_zh_transfer, read_lightmap_transfer,
// read_wavelet_lightmap, read_probe_transfer) on every input.
//
// The checksum: the trailer holds XXH3-64 of every byte before it, which a
// mutated input almost never matches, so the reader would stop there. When
// an input ends with the end marker "PRTE", the target writes the checksum of
// the mutated bytes into the trailer before reading, and the fuzzer reaches
// the header, the section table and the values. Inputs without the marker
// are read as they are (the truncation and size messages).
//
// Promises: what read_transfer_file accepts, write_transfer_file writes in
// file_size(t) bytes, and reading that back as its kind (read_transfer_as)
// and writing it again gives the same bytes. A file is of one kind: the
// reader of the kind read_transfer_file names accepts it and every other
// kind's reader refuses it; a file read_transfer_file refuses, every
// reader refuses.
#include "fuzz_util.h"

#include <prt/hash.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <array>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

namespace {

std::vector<char> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// write_transfer_file(t), read back as its kind and written again: the same bytes, file_size(t) of them.
template <typename T>
void round_trip(const T& t, const prt::AnyTransfer& any) {
  static const std::string a = prt::fuzz::scratch_path("written-a.prt");
  static const std::string b = prt::fuzz::scratch_path("written-b.prt");
  try {
    prt::write_transfer_file(a, t);
    prt::write_transfer_file(b, prt::read_transfer_as<T>(a));
  } catch (const prt::Error& e) {
    prt::fuzz::finding(std::string("a transfer read back fails to write or read again: ") + e.what());
  }
  const std::vector<char> written = file_bytes(a);
  if (written != file_bytes(b)) prt::fuzz::finding("write(read(write(t))) differs from write(t)");
  if (written.size() != prt::file_size(any)) prt::fuzz::finding("file_size(t) is not the size written");
}

// What each kind's consumers ask of what was read (prt info, prt relight,
// the tools' size reports), then the round trip.
void exercise(const prt::AnyTransfer& any) {
  (void)prt::describe(any);
  const auto common = [&](const auto& t) {
    (void)prt::describe_transfer(t);
    (void)prt::transfer_sections(t);
    round_trip(t, any);
  };
  prt::dispatch(
      any,
      [&](const prt::Transfer& t) {
        (void)prt::transfer_bytes_per_vertex(t);
        (void)prt::analytic_bytes_saved(t);
        common(t);
      },
      [&](const prt::CompressedTransfer& c) {
        (void)prt::decompress(c);
        common(c);
      },
      [&](const prt::WaveletTransfer& t) { common(t); },
      [&](const prt::ZhTransfer& t) { common(t); },
      [&](const prt::LightmapTransfer& l) { common(l); },  // version 5, or 7 with its interpolated-texel mask
      [&](const prt::WaveletLightmap& l) { common(l); },
      [&](const prt::ProbeTransfer& p) {
        (void)p.bytes();
        common(p);
      });
}

// Each kind's own reader on `path`, in TransferKind's order: whether it accepted the file.
std::array<bool, prt::kTransferKinds> typed_reads(const std::string& path) {
  // std::to_array takes its size from the list: a kind without a reader here
  // fails the static_assert (a std::array of kTransferKinds would be padded
  // with an empty function).
  const auto readers = std::to_array<std::function<void()>>(
      {[&] { (void)prt::read_transfer(path); }, [&] { (void)prt::read_compressed_transfer(path); },
       [&] { (void)prt::read_wavelet_transfer(path); }, [&] { (void)prt::read_zh_transfer(path); },
       [&] { (void)prt::read_lightmap_transfer(path); }, [&] { (void)prt::read_wavelet_lightmap(path); },
       [&] { (void)prt::read_probe_transfer(path); }});
  static_assert(readers.size() == prt::kTransferKinds, "a typed reader for every kind, in TransferKind's order");
  std::array<bool, prt::kTransferKinds> accepted{};
  for (std::size_t k = 0; k < readers.size(); ++k)
    prt::fuzz::expect_only_prt_errors([&] {
      readers[k]();
      accepted[k] = true;
    });
  return accepted;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = prt::fuzz::scratch_path("transfer.prt");
  std::vector<std::uint8_t> bytes(data, data + size);
  constexpr std::size_t kTrailer = 12;  // u64 checksum, "PRTE"
  if (size >= kTrailer && std::memcmp(data + size - 4, "PRTE", 4) == 0) {
    const std::uint64_t sum = prt::hash64(bytes.data(), size - kTrailer);
    std::memcpy(bytes.data() + size - kTrailer, &sum, sizeof sum);  // little-endian, as the format
  }
  prt::fuzz::write_file(path, bytes.data(), bytes.size());

  std::optional<prt::AnyTransfer> any;
  std::uint32_t version = 0;
  prt::fuzz::expect_only_prt_errors([&] { any = prt::read_transfer_file(path, &version); });
  const bool read = any.has_value();
  const std::size_t kind = read ? any->index() : 0;
  if (read) {
    if (version < 1 || version > prt::kTransferFormatVersion) prt::fuzz::finding("the format version out of range");
    // Accepted: no consumer may refuse it (nor crash).
    try {
      exercise(*any);
    } catch (const prt::Error& e) {
      prt::fuzz::finding(std::string("a transfer the reader accepts is refused by a consumer: ") + e.what());
    }
  }
  const std::array<bool, prt::kTransferKinds> accepted = typed_reads(path);
  for (std::size_t k = 0; k < accepted.size(); ++k)
    if (accepted[k] != (read && k == kind))
      prt::fuzz::finding(std::string("the reader of kind '") + std::string(prt::kind_names(prt::TransferKind(k)).id) +
                         (accepted[k] ? "' accepts a file read_transfer_file " +
                                            std::string(read ? "reads as another kind" : "refuses")
                                      : "' refuses a file read_transfer_file reads as that kind"));
  return 0;
}
