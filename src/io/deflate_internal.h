// Internal (not installed): one step of zlib's deflate over an input, shared by the PNG writer
// (drawing.cpp) and the gzip-compressed MRPT files (mrpt_maps.cpp).
#pragma once

#include <zlib.h>

#include <string>
#include <string_view>

#include "shape_slam_io/atomic_file.h"

namespace shape_slam::io::internal {

/// Compresses all of `in` with the started stream `z` (Z_NO_FLUSH; Z_FINISH ends the stream),
/// handing each block of output, up to 64 KiB, to `out(std::string_view)` as it comes. Throws
/// OutputError(`what`) when zlib reports a stream error.
template <typename Out>
void DeflateInto(z_stream& z, std::string_view in, int flush, const char* what, const Out& out) {
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  int status = Z_OK;
  do {
    char buffer[1 << 16];
    z.next_out = reinterpret_cast<Bytef*>(buffer);
    z.avail_out = sizeof(buffer);
    status = deflate(&z, flush);
    if (status == Z_STREAM_ERROR) throw OutputError(what);
    const std::size_t produced = sizeof(buffer) - z.avail_out;
    if (produced > 0) out(std::string_view(buffer, produced));
  } while (z.avail_out == 0 || (flush == Z_FINISH && status != Z_STREAM_END));
}

}  // namespace shape_slam::io::internal
