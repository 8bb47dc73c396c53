// prt/file_info.h - what a prt file holds, as the JSON object `prt info
// --json` prints (docs/FORMAT.md): header fields, section sizes and derived
// figures, for every kind of transfer file and probe volume.
#pragma once

#include <string>

namespace prt {

// Reads and validates the whole file (any basis, compressed, lightmap, probe
// volume) and returns its description as a JSON object (text, 2-space
// indented). Throws prt::Error naming the file for a file that is not a
// valid prt file. Hashes are hex strings (a 64-bit integer does not survive
// JSON readers that use doubles).
std::string file_info_json(const std::string& path);

}  // namespace prt
