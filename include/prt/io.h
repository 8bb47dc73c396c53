// prt/io.h - writing outputs safely.
#pragma once

#include <functional>
#include <string>

namespace prt {

// Calls write(tmp) with a temporary path in the same directory as `path` and
// the same extension, then renames it over `path`. If write throws, or the
// rename fails, the temporary file is removed and `path` is untouched.
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// Writes `text` to `path` through write_atomically. Throws prt::Error.
void write_text_file(const std::string& path, const std::string& text);

}  // namespace prt
