// prt/paths.h - where prt finds its own files at run time: the OpenImageIO
// plugin and the bundled data (environment maps).
//
// No absolute path is compiled in. prt looks relative to the file that holds
// prt::core, so an installed tree still works after it is moved (or unpacked
// under another prefix), and the build tree, laid out the same way, works
// as it is:
//
//   install tree                         build tree
//   <prefix>/bin/prt                     build/prt
//   <prefix>/lib/libprt_core.so          build/lib/libprt_core.so       <- library_dir()
//   <prefix>/lib/prt/libprt_oiio.so      build/lib/prt/libprt_oiio.so   <- plugin_dir()
//   <prefix>/share/prt/envmaps/          build/share/prt/envmaps/       <- data_dir()
//
// "lib" and "share" stand for CMAKE_INSTALL_LIBDIR and CMAKE_INSTALL_DATADIR;
// what is compiled in is only the relative path from the one to the other
// (by default "../share/prt") and, for a statically linked prt::core, the
// one from CMAKE_INSTALL_BINDIR to CMAKE_INSTALL_LIBDIR ("../lib").
#pragma once

#include <filesystem>
#include <vector>

namespace prt {

// The directory of the file that holds prt::core: the shared library
// libprt_core.so (found with dladdr on one of its functions), or, when
// prt::core is linked statically, the executable's directory
// (/proc/self/exe). Symbolic links are resolved. Empty when neither can be
// found. Computed once.
std::filesystem::path library_dir();

// The directories that stand for <libdir> in the layout above, in the order
// searched: with a shared prt::core, library_dir() alone; with a static one
// (library_dir() is then the executable's), <exe dir>/../lib (an installed
// bin/prt) and <exe dir>/lib (the build tree's build/prt). Computed once.
std::vector<std::filesystem::path> library_dirs();

// The directory holding prt's OpenImageIO plugin, libprt_oiio.so (every
// image format but EXR, loaded on first use). $PRT_PLUGIN_DIR when set and
// not empty (then nothing else is searched); else <d>/prt for the first d of
// library_dirs() where <d>/prt/libprt_oiio.so exists; else
// <library_dirs()[0]>/prt, which does not hold it (loading then fails with
// a message naming the files tried and PRT_PLUGIN_DIR).
std::filesystem::path plugin_dir();

// The directory holding prt's data (envmaps/: the bundled maps and their
// LICENSE.txt). $PRT_DATA_DIR when set and not empty (then nothing else is
// searched); else <d>/../share/prt (the relative path from
// CMAKE_INSTALL_LIBDIR to CMAKE_INSTALL_DATADIR, then prt) for the first d of
// library_dirs() where that directory exists; else the one for
// library_dirs()[0], which does not exist.
std::filesystem::path data_dir();

}  // namespace prt
