// Fuzz target: the vertex CSV reader (prt/vertex_csv.h), with and without
// the standard-error columns requested. Round trip: what it reads,
// write_vertex_csv writes, and reading that back gives the same floats.
#include "fuzz_util.h"

#include <prt/vertex_csv.h>

#include <cstring>
#include <vector>

namespace {

bool same_bits(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(glm::vec3)) == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = prt::fuzz::scratch_path("vertices.csv");
  static const std::string again = prt::fuzz::scratch_path("written.csv");
  prt::fuzz::write_file(path, data, size);
  prt::fuzz::expect_only_prt_errors([&] {
    std::vector<glm::vec3> se;
    const std::vector<glm::vec3> rgb = prt::read_vertex_csv(path, &se);
    if (!se.empty() && se.size() != rgb.size()) prt::fuzz::finding("standard errors and values differ in count");
    if (!same_bits(prt::read_vertex_csv(path), rgb)) prt::fuzz::finding("the values depend on asking for std_error");
    std::vector<glm::vec3> se2;
    try {
      prt::write_vertex_csv(again, rgb, se.empty() ? nullptr : &se);
      if (!same_bits(prt::read_vertex_csv(again, &se2), rgb) || !same_bits(se2, se))
        prt::fuzz::finding("read(write(values)) differs from the values");
    } catch (const prt::Error& e) {
      prt::fuzz::finding(std::string("values read fail to write or read again: ") + e.what());
    }
  });
  return 0;
}
