// Fuzz target: the transfer file reader (docs/FORMAT.md), every basis:
// read_transfer_basis, read_transfer_version, transfer_is_compressed,
// transfer_is_lightmap, read_transfer, read_compressed_transfer,
// read_lightmap_transfer, read_wavelet_transfer and read_zh_transfer, and the
// description of what was read.
//
// The checksum: the trailer holds XXH3-64 of every byte before it, which a
// mutated input almost never matches, so the reader would stop there. When
// an input ends with the end marker "PRTE", the target writes the checksum of
// the mutated bytes into the trailer before reading, and the fuzzer reaches
// the header, the section table and the values. Inputs without the marker
// are read as they are (the truncation and size messages).
//
// Round trip: what read_* accepts, write_* must write, and reading that back
// and writing it again must give the same bytes.
#include "fuzz_util.h"

#include <prt/hash.h>
#include <prt/transfer_io.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

namespace {

std::vector<char> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

template <typename T, typename Read, typename Write>
void round_trip(const T& t, Read read, Write write) {
  static const std::string a = prt::fuzz::scratch_path("written-a.prt");
  static const std::string b = prt::fuzz::scratch_path("written-b.prt");
  try {
    write(a, t);
    write(b, read(a));
  } catch (const prt::Error& e) {
    prt::fuzz::finding(std::string("a transfer read back fails to write or read again: ") + e.what());
  }
  if (file_bytes(a) != file_bytes(b)) prt::fuzz::finding("write(read(write(t))) differs from write(t)");
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

  prt::fuzz::expect_only_prt_errors([&] {
    const std::uint32_t version = prt::read_transfer_version(path);
    if (version < 1 || version > prt::kTransferFormatVersion) prt::fuzz::finding("read_transfer_version out of range");
    if (prt::read_transfer_basis(path) == prt::TransferBasis::SH && prt::transfer_is_compressed(path)) {
      const prt::CompressedTransfer c = prt::read_compressed_transfer(path);
      (void)prt::describe_transfer(c);
      (void)prt::decompress(c);
      round_trip(c, prt::read_compressed_transfer,
                 [](const std::string& p, const prt::CompressedTransfer& x) { prt::write_compressed_transfer(p, x); });
    } else if (prt::read_transfer_basis(path) == prt::TransferBasis::SH && prt::transfer_is_lightmap(path)) {
      // An SH lightmap: version 5, or 7 with its interpolated-texel mask.
      const prt::LightmapTransfer l = prt::read_lightmap_transfer(path);
      (void)prt::describe_transfer(l);
      (void)prt::transfer_sections(l);
      round_trip(l, prt::read_lightmap_transfer,
                 [](const std::string& p, const prt::LightmapTransfer& x) { prt::write_lightmap_transfer(p, x); });
    } else if (prt::read_transfer_basis(path) == prt::TransferBasis::SH) {
      const prt::Transfer t = prt::read_transfer(path);
      (void)prt::describe_transfer(t);
      (void)prt::transfer_sections(t);
      (void)prt::transfer_bytes_per_vertex(t);
      (void)prt::analytic_bytes_saved(t);
      round_trip(t, prt::read_transfer, [](const std::string& p, const prt::Transfer& x) { prt::write_transfer(p, x); });
    } else if (prt::read_transfer_basis(path) == prt::TransferBasis::ZH) {
      const prt::ZhTransfer t = prt::read_zh_transfer(path);
      (void)prt::describe_transfer(t);
      (void)prt::transfer_sections(t);
      round_trip(t, prt::read_zh_transfer, [](const std::string& p, const prt::ZhTransfer& x) { prt::write_zh_transfer(p, x); });
    } else {
      const prt::WaveletTransfer t = prt::read_wavelet_transfer(path);
      (void)prt::describe_transfer(t);
      (void)prt::transfer_sections(t);
      round_trip(t, prt::read_wavelet_transfer,
                 [](const std::string& p, const prt::WaveletTransfer& x) { prt::write_wavelet_transfer(p, x); });
    }
  });
  // The other basis's reader refuses the file (with a prt::Error).
  prt::fuzz::expect_only_prt_errors([&] { (void)prt::read_wavelet_transfer(path); });
  prt::fuzz::expect_only_prt_errors([&] { (void)prt::read_transfer(path); });
  prt::fuzz::expect_only_prt_errors([&] { (void)prt::read_compressed_transfer(path); });
  prt::fuzz::expect_only_prt_errors([&] { (void)prt::read_lightmap_transfer(path); });
  prt::fuzz::expect_only_prt_errors([&] { (void)prt::read_zh_transfer(path); });
  return 0;
}
