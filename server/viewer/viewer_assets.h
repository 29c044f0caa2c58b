// The viewer's static page (server/viewer/www), embedded into the binary at build time
// (embed_assets.cmake), so that caustica-server serves it without files beside it.
#pragma once

#include <string_view>

namespace caustica::server::viewer {

struct ViewerAsset {
  std::string_view path;          // "/index.html", "/viewer.js", ...
  std::string_view content_type;  // with charset for text
  std::string_view etag;          // quoted, from the content's SHA-256
  std::string_view body;
};

// The asset served at `path` ("/" is the page), or null.
const ViewerAsset* find_viewer_asset(std::string_view path);

// The Content-Type of a file name by its extension; application/octet-stream when unknown.
std::string_view content_type_of(std::string_view file_name);

}  // namespace caustica::server::viewer
