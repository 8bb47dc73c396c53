// The C interface between prt::core and its OpenImageIO plugin
// (libprt_oiio.so, loaded with dlopen). Plain C so no C++ ABI crosses it.
#pragma once

#include <stddef.h>

extern "C" {

typedef struct prt_oiio_reader prt_oiio_reader;

// Opens `path` and reads its header. On success returns a reader (close it
// with prt_oiio_close) and sets *width, *height, *channels, *srgb (1 when the
// file holds sRGB-encoded integer data) and *streams (1 when rows are read
// from the file as asked; 0 when the file is tiled and was read whole here).
// On failure returns NULL and writes a message into err.
typedef prt_oiio_reader* (*prt_oiio_open_fn)(const char* path, int* width, int* height, int* channels, int* srgb,
                                             int* streams, char* err, size_t err_len);
// Reads rows [y0, y1) as float pixels, all channels, into data
// ((y1 - y0) * width * channels floats). Rows are read in order. Returns 0,
// or non-zero with a message in err.
typedef int (*prt_oiio_read_rows_fn)(prt_oiio_reader* reader, int y0, int y1, float* data, char* err,
                                     size_t err_len);
typedef void (*prt_oiio_close_fn)(prt_oiio_reader* reader);
// Writes 3-channel pixels: float when `floating`, else 8-bit from `bytes`.
typedef int (*prt_oiio_write_fn)(const char* path, const char* format_from, int width, int height,
                                 const float* rgb, const unsigned char* bytes, int floating, char* err,
                                 size_t err_len);
}
