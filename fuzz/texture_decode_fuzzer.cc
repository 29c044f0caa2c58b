// Texture image files as an upload brings them, through decode_image: the format told by the
// bytes, then libpng, libjpeg-turbo, OpenEXR or stb_image (TGA, Radiance HDR). Every input either
// decodes to pixels or is refused with a status.
#include <cstddef>
#include <cstdint>

#include "renderer/scene/texture_decode.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::StatusOr<caustica::DecodedImage> image = caustica::decode_image(
      absl::string_view(reinterpret_cast<const char*>(data), size), "fuzz.image");
  // A decoded image has its pixels, four channels of each.
  if (image.ok()) {
    const size_t texels = size_t(image->width) * image->height;
    if (texels == 0 || (image->rgba8.size() != 4 * texels && image->rgba32f.size() != 4 * texels)) {
      __builtin_trap();
    }
  }
  return 0;
}
