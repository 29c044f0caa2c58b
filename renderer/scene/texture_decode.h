// Texture images from their files' bytes: PNG through libpng, JPEG through libjpeg-turbo, OpenEXR
// through OpenEXR, TGA and Radiance HDR through stb_image (Debian's libstb). The format is told
// by the bytes, not the name. The server decodes what an upload brings; a file that does not
// decode is refused by name (docs/scene-format.md, "Textures").
#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "renderer/scene/scene.h"

namespace caustica {

enum class ImageFormat { kUnknown, kPng, kJpeg, kOpenExr, kRadianceHdr, kTga };

// The format of a file from its first bytes; TGA, which has no signature, is told by its header's
// fields. kUnknown for anything else.
ImageFormat sniff_image_format(absl::string_view bytes);
const char* image_format_name(ImageFormat format);

// Decodes one image. Errors name `name` and say what is wrong (unknown format, truncated or
// corrupt data, a side beyond kMaxTextureSide, more than kMaxTextureDecodedBytes decoded);
// RESOURCE_EXHAUSTED for the limits, INVALID_ARGUMENT for the rest. Sizes are checked before the
// pixels are allocated.
absl::StatusOr<DecodedImage> decode_image(absl::string_view bytes, absl::string_view name);

// Decodes every texture of `scene` that is not decoded yet; errors name the texture
// (`textures[2] 'wood.png': ...`). On error the scene's textures are left as they were.
absl::Status decode_textures(Scene& scene);

// Bytes the decoded textures of `scene` hold.
size_t decoded_texture_bytes(const Scene& scene);

}  // namespace caustica
