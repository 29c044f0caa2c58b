// glTF 2.0 files read through tinygltf, and what the mesh loader (mesh_gltf.h) and the animation
// sampler (gltf_animation.h) both read of them: accessors checked against their buffers, the
// node hierarchy, and the names meshes get. Internal to the scene module.
#pragma once

// The Debian package ships tinygltf as a compiled library, so no TINYGLTF_IMPLEMENTATION here.
// No stb_image: images travel to the server as their files' bytes (texture_decode.h decodes them
// there), so the image callback only keeps the bytes.
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "renderer/base/vec.h"
#include "renderer/scene/affine.h"

namespace caustica {

// glTF buffers are little-endian, and we read them with memcpy.
static_assert(std::endian::native == std::endian::little);

// The bytes of every image of the file (embedded, in a buffer view or beside it), by index.
using ImageBytes = std::vector<std::string>;

// The file's model; the images' bytes go to `images` when given. glTF 1.0 files are refused with
// advice on converting them; every error names the file.
absl::StatusOr<tinygltf::Model> load_gltf_model(const std::filesystem::path& path,
                                                ImageBytes* images);

namespace gltf_detail {
inline bool checked_add(size_t a, size_t b, size_t* sum) {
  return !__builtin_add_overflow(a, b, sum);
}
inline bool checked_mul(size_t a, size_t b, size_t* product) {
  return !__builtin_mul_overflow(a, b, product);
}
}  // namespace gltf_detail

// An accessor whose whole byte range has been checked to lie inside its buffer, so that reads
// cannot leave it whatever the file claims.
class AccessorView {
 public:
  static absl::StatusOr<AccessorView> open(const tinygltf::Model& model, int index, int type,
                                           std::initializer_list<int> component_types,
                                           absl::string_view what) {
    auto fail = [&](absl::string_view problem) {
      return absl::InvalidArgumentError(absl::StrCat(what, " (accessor ", index, "): ", problem));
    };
    if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
      return fail("no such accessor");
    }
    const tinygltf::Accessor& accessor = model.accessors[index];
    if (accessor.sparse.isSparse) return fail("sparse accessors are not supported");
    if (accessor.type != type) return fail("unexpected element type");
    bool known_component = false;
    for (int c : component_types) known_component |= accessor.componentType == c;
    if (!known_component) {
      return fail(absl::StrCat("unsupported component type ", accessor.componentType));
    }
    if (accessor.bufferView < 0 ||
        static_cast<size_t>(accessor.bufferView) >= model.bufferViews.size()) {
      return fail("has no valid bufferView");
    }
    const tinygltf::BufferView& view = model.bufferViews[accessor.bufferView];
    if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size()) {
      return fail("bufferView has no valid buffer");
    }
    const std::vector<unsigned char>& buffer = model.buffers[view.buffer].data;

    AccessorView result;
    result.component_type_ = accessor.componentType;
    result.normalized_ = accessor.normalized;
    result.components_ = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type));
    result.component_size_ = tinygltf::GetComponentSizeInBytes(accessor.componentType);
    result.count_ = accessor.count;
    const size_t element_size = result.components_ * result.component_size_;
    result.stride_ = view.byteStride != 0 ? view.byteStride : element_size;
    if (result.stride_ < element_size) return fail("byteStride is smaller than an element");

    size_t view_end = 0, start = 0, last = 0, end = 0;
    if (!gltf_detail::checked_add(view.byteOffset, view.byteLength, &view_end) ||
        view_end > buffer.size()) {
      return fail("bufferView runs past the end of its buffer");
    }
    if (!gltf_detail::checked_add(view.byteOffset, accessor.byteOffset, &start))
      return fail("bad byteOffset");
    if (result.count_ > 0) {
      if (!gltf_detail::checked_mul(result.count_ - 1, result.stride_, &last) ||
          !gltf_detail::checked_add(start, last, &last) ||
          !gltf_detail::checked_add(last, element_size, &end) || end > view_end) {
        return fail(absl::StrCat(result.count_, " elements run past the end of the bufferView"));
      }
    }
    if (result.count_ > 0) result.data_ = buffer.data() + start;
    return result;
  }

  size_t count() const { return count_; }

  // Component c of element i; normalized integers map to [0, 1] or [-1, 1] as glTF specifies.
  double get(size_t i, int c) const {
    const unsigned char* p = data_ + i * stride_ + size_t(c) * component_size_;
    switch (component_type_) {
      case TINYGLTF_COMPONENT_TYPE_BYTE:
        return scaled<int8_t>(p, 127.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return scaled<uint8_t>(p, 255.0);
      case TINYGLTF_COMPONENT_TYPE_SHORT:
        return scaled<int16_t>(p, 32767.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
        return scaled<uint16_t>(p, 65535.0);
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        return load<uint32_t>(p);
      case TINYGLTF_COMPONENT_TYPE_FLOAT:
        return load<float>(p);
      default:
        return 0;
    }
  }

  Vec3f get_vec3(size_t i) const {
    return {static_cast<float>(get(i, 0)), static_cast<float>(get(i, 1)),
            static_cast<float>(get(i, 2))};
  }

 private:
  template <typename T>
  static double load(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return static_cast<double>(v);
  }
  template <typename T>
  double scaled(const unsigned char* p, double max) const {
    const double v = load<T>(p);
    return normalized_ ? std::max(v / max, -1.0) : v;
  }

  const unsigned char* data_ = nullptr;
  size_t count_ = 0;
  size_t stride_ = 0;
  size_t component_size_ = 0;
  int components_ = 0;
  int component_type_ = 0;
  bool normalized_ = false;
};

// The default scene's roots; without scenes, every node that is nobody's child.
std::vector<int> gltf_root_nodes(const tinygltf::Model& model);
// A node's own transform: its matrix, or translation * rotation * scale.
Affine gltf_local_transform(const tinygltf::Node& node);
// What the loader calls primitive `primitive` of node `node`'s mesh: "mesh 'NAME' primitive P at
// node 'NODE'" (the node's index where it has no name); mesh names put the file's name first.
std::string gltf_primitive_name(const tinygltf::Model& model, int node, size_t primitive);
// Whether the loader makes a mesh of the primitive: TRIANGLES (the default), strips and fans.
bool gltf_draws_triangles(const tinygltf::Primitive& primitive);

}  // namespace caustica
