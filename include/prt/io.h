// prt/io.h - writing outputs safely.
#pragma once

#include <functional>
#include <string>

namespace prt {

// Calls write(tmp) with a temporary path in the same directory as `path` and
// the same extension, then renames it over `path`. If write throws, or the
// rename fails, the temporary file is removed and `path` is untouched.
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// Throws prt::Error naming `path` unless its directory exists and is
// writable and `path` is not a directory. Lets a command refuse bad output
// paths before doing any work.
void check_writable(const std::string& path);

// Writes `text` to `path` through write_atomically. Throws prt::Error.
void write_text_file(const std::string& path, const std::string& text);

}  // namespace prt
