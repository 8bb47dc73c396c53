// The C interface between prt::core and its OpenImageIO plugin
// (libprt_oiio.so, loaded with dlopen). Plain C so no C++ ABI crosses it.
#pragma once

#include <stddef.h>

extern "C" {

// Reads `path` as float pixels. On success returns 0 and sets *data (free with
// prt_oiio_free), *width, *height, *channels, *srgb (1 when the file holds
// sRGB-encoded integer data). On failure returns non-zero and writes a
// message into err.
typedef int (*prt_oiio_read_fn)(const char* path, float** data, int* width, int* height, int* channels, int* srgb,
                                char* err, size_t err_len);
typedef void (*prt_oiio_free_fn)(float* data);
// Writes 3-channel pixels: float when `floating`, else 8-bit from `bytes`.
typedef int (*prt_oiio_write_fn)(const char* path, const char* format_from, int width, int height,
                                 const float* rgb, const unsigned char* bytes, int floating, char* err,
                                 size_t err_len);
}
