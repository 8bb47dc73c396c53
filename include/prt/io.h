// prt/io.h - reading inputs and writing outputs safely.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

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
// the same extension (".NAME.tmpPID-N.EXT"), then renames it over `path`. If
// write throws, or the rename fails, the temporary file is removed and `path`
// is untouched. While a StagedWrites::Scope is active on the calling thread
// the rename is left to StagedWrites::commit() instead. An existing device,
// FIFO or socket (/dev/stdout) is written in place, neither renamed nor
// staged.
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// Files written together: all of them appear, or none. While a Scope is
// active on a thread, write_atomically on that thread writes each file's
// temporary as usual and records it here instead of renaming it; commit()
// renames them all, discard() (or the destructor, when not committed)
// removes them. A command stages its outputs (a transfer file, the frames of
// a sequence, coefficients and a reconstruction) so that a failure or Ctrl-C
// at any point leaves the old files and no temporary. Writing the same path
// twice keeps the second version.
class StagedWrites {
 public:
  StagedWrites() = default;
  ~StagedWrites();  // discard()s what was not committed
  StagedWrites(const StagedWrites&) = delete;
  StagedWrites& operator=(const StagedWrites&) = delete;

  // Stages this thread's write_atomically calls into `staged` while it lives.
  class Scope {
   public:
    explicit Scope(StagedWrites& staged);
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StagedWrites* previous_;
  };

  // Renames every staged temporary over its path, in the order staged. When
  // a rename fails, the temporaries not yet renamed are removed, so are the
  // files this commit created (not those it replaced: their old contents are
  // gone), and prt::Error names the file.
  void commit();
  void discard();  // removes every staged temporary
  std::size_t size() const { return staged_.size(); }

  // Called by write_atomically: `tmp` is complete and belongs at `path`.
  void stage(const std::string& tmp, const std::string& path, const std::string& shown);

 private:
  struct Entry {
    std::string tmp, path, shown;  // shown: the path as the caller gave it, for messages
    bool existed = false;          // path existed when staged (commit replaces it)
  };
  std::vector<Entry> staged_;
};

// Throws prt::Error naming `path` unless its directory exists and is
// writable and `path` is not a directory. Lets a command refuse bad output
// paths before doing any work.
void check_writable(const std::string& path);

// Writes `text` to `path` through write_atomically. Throws prt::Error.
void write_text_file(const std::string& path, const std::string& text);

// Whether a and b name the same file: std::filesystem::equivalent when both
// exist (also through a symbolic or hard link), else the same absolute,
// normalised path (a file not written yet). Empty names name no file. What
// refuses an output that is one of a call's inputs, or another of its
// outputs (prt's commands: no output may be one of the inputs).
bool same_file(const std::string& a, const std::string& b);

}  // namespace prt
