// prt/io.h - reading inputs and writing outputs safely.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace prt {

// Throws prt::Error naming `path` unless it is a regular file prt can read,
// and returns its size in bytes (0 for an empty file: each reader says what
// an empty file of its kind is). Every input prt opens (meshes and the files
// they reference, maps, transfer files, vertex CSV) goes through it first,
// so a FIFO, a device such as /dev/zero or a socket is refused before it is
// opened, instead of blocking or being read without end. The messages:
// "PATH: no such file", "PATH: too many levels of symbolic links" (a loop),
// "PATH: is a directory, not KIND", "PATH: is a FIFO (named pipe), not a
// regular file" (likewise a character device, block device, socket),
// "PATH: permission denied". `kind` names what was expected ("a mesh file").
std::uint64_t check_input_file(const std::string& path, std::string_view kind = "a file");

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
