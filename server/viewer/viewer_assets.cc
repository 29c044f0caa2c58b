#include "server/viewer/viewer_assets.h"

namespace caustica::server::viewer {

std::string_view content_type_of(std::string_view file_name) {
  struct Type {
    std::string_view extension, content_type;
  };
  static constexpr Type kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".ico", "image/x-icon"},
      {".json", "application/json"},
  };
  for (const Type& type : kTypes) {
    if (file_name.ends_with(type.extension)) return type.content_type;
  }
  return "application/octet-stream";
}

}  // namespace caustica::server::viewer
