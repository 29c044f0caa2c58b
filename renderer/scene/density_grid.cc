#include "renderer/scene/density_grid.h"

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridValidator.h>
#include <nanovdb/util/IO.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace caustica {
namespace {

using Grid = nanovdb::NanoGrid<float>;
using Root = nanovdb::NanoRoot<float>;
using Upper = nanovdb::NanoUpper<float>;
using Lower = nanovdb::NanoLower<float>;
using Leaf = nanovdb::NanoLeaf<float>;

absl::Status grid_error(const std::string& field, const std::string& problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

// Every value a grid holds and every node it points at, walked from the root with each node
// checked to lie inside the buffer before it is read. NanoVDB's validator bounds the root's
// tiles and the internal nodes; this walk bounds the leaves too, and reads the values.
struct GridSurvey {
  std::string problem;  // empty when the grid is whole and its values fit a density
  float min_value = 0.0f;
  float max_value = 0.0f;
  nanovdb::CoordBBox nonzero;  // the voxels (tiles counted whole) whose value is not 0
  bool any_nonzero = false;
  uint64_t active_voxels = 0;
};

class Surveyor {
 public:
  Surveyor(const uint8_t* begin, size_t size) : begin_(begin), end_(begin + size) {}

  GridSurvey survey(const Grid& grid) {
    const Root& root = grid.tree().root();
    value(root.background(), nanovdb::CoordBBox());
    if (!out_.problem.empty()) return out_;
    if (root.background() != 0.0f) {
      out_.problem = absl::StrCat("the background value is ", root.background(),
                                  "; a density grid's is 0, or the medium would fill all space");
      return out_;
    }
    const auto* data = root.data();
    for (uint32_t i = 0; i < data->mTableSize && out_.problem.empty(); ++i) {
      const auto* tile = data->tile(i);
      if (tile->isChild()) {
        if (const Upper* upper = node_at<Upper>(data, tile->child, "an upper node")) walk(*upper);
      } else {
        const nanovdb::Coord origin = tile->origin();
        value(tile->value, nanovdb::CoordBBox(origin, origin.offsetBy(Upper::DIM - 1)));
      }
    }
    out_.active_voxels = grid.activeVoxelCount();
    return out_;
  }

 private:
  // The node `offset` bytes from `base` (a node inside the buffer), as NanoVDB links children,
  // or null with the problem noted when it would not lie whole and aligned inside the buffer.
  // Checked on the offset before a pointer is formed: NanoVDB's getChild adds it unchecked, and a
  // pointer computed past the buffer is undefined behaviour even if it is never read.
  template <typename Node>
  const Node* node_at(const void* base, int64_t offset, const char* what) {
    const int64_t size = end_ - begin_;
    const int64_t from = reinterpret_cast<const uint8_t*>(base) - begin_;
    const int64_t last = size - static_cast<int64_t>(sizeof(Node));
    if (last < 0 || offset < -from || offset > last - from ||
        (from + offset) % NANOVDB_DATA_ALIGNMENT != 0) {
      out_.problem = absl::StrCat(what, " lies outside the grid's buffer");
      return nullptr;
    }
    return reinterpret_cast<const Node*>(begin_ + (from + offset));
  }

  // One value, covering `box` (empty for the background).
  void value(float v, const nanovdb::CoordBBox& box) {
    if (!std::isfinite(v) || v < 0.0f) {
      out_.problem = absl::StrCat("holds the value ", v, "; a density is finite and >= 0");
      return;
    }
    out_.min_value = std::min(out_.min_value, v);
    out_.max_value = std::max(out_.max_value, v);
    if (v != 0.0f && !box.empty()) {
      if (out_.any_nonzero) {
        out_.nonzero.expand(box.min());
        out_.nonzero.expand(box.max());
      } else {
        out_.nonzero = box;
        out_.any_nonzero = true;
      }
    }
  }

  template <typename Node, typename Child>
  void walk_internal(const Node& node, const char* child_name, auto&& walk_child) {
    for (auto it = node.beginValue(); it && out_.problem.empty(); ++it) {
      const nanovdb::Coord origin = node.offsetToGlobalCoord(it.pos());
      value(*it, nanovdb::CoordBBox(origin, origin.offsetBy(Child::DIM - 1)));
    }
    for (auto it = node.beginChild(); it && out_.problem.empty(); ++it) {
      const int64_t offset = node.data()->mTable[it.pos()].child;
      if (const Child* child = node_at<Child>(node.data(), offset, child_name)) walk_child(*child);
    }
  }

  void walk(const Upper& upper) {
    walk_internal<Upper, Lower>(upper, "a lower node", [this](const Lower& lower) {
      walk_internal<Lower, Leaf>(lower, "a leaf", [this](const Leaf& leaf) {
        for (auto it = leaf.beginValue(); it && out_.problem.empty(); ++it) {
          const nanovdb::Coord c = it.getCoord();
          value(*it, nanovdb::CoordBBox(c, c));
        }
      });
    });
  }

  const uint8_t* begin_;
  const uint8_t* end_;
  GridSurvey out_;
};

// The header checks that must pass before any offset in the buffer is followed.
absl::Status check_header(const AlignedBytes& bytes, const std::string& field) {
  const size_t size = bytes.size();
  if (size < sizeof(nanovdb::GridData) + sizeof(nanovdb::TreeData<>)) {
    return grid_error(field, absl::StrCat(size, " bytes are too few for a NanoVDB grid"));
  }
  const auto* data = reinterpret_cast<const nanovdb::GridData*>(bytes.data());
  if (data->mMagic != NANOVDB_MAGIC_NUMBER) {
    return grid_error(field, "is not a NanoVDB grid (its magic number is wrong)");
  }
  if (const nanovdb::Version version = data->mVersion;
      version.getMajor() != NANOVDB_MAJOR_VERSION_NUMBER) {
    // Not Version::c_str(): it returns a malloc'd string that every such grid would leak.
    return grid_error(
        field, absl::StrCat("was written by NanoVDB ", version.getMajor(), ".", version.getMinor(),
                            ".", version.getPatch(), "; this build reads version ",
                            NANOVDB_MAJOR_VERSION_NUMBER, ".x"));
  }
  if (data->mGridType != nanovdb::GridType::Float) {
    // toStr indexes a table with the type, which a damaged grid can put past the table's end.
    const std::string type =
        data->mGridType < nanovdb::GridType::End
            ? std::string(nanovdb::toStr(data->mGridType))
            : absl::StrCat("unknown type ", static_cast<uint32_t>(data->mGridType));
    return grid_error(field, absl::StrCat("is a grid of ", type, "; a density grid holds floats"));
  }
  if (data->mGridSize != size) {
    return grid_error(field, absl::StrCat("says it is ", data->mGridSize, " bytes long but ", size,
                                          " bytes arrived"));
  }
  const auto* tree = reinterpret_cast<const nanovdb::TreeData<>*>(data + 1);
  const uint64_t root_offset = sizeof(nanovdb::GridData) + tree->mNodeOffset[3];
  if (root_offset < sizeof(nanovdb::GridData) + sizeof(nanovdb::TreeData<>) ||
      root_offset > size - sizeof(Root::DataType)) {
    return grid_error(field, "its root node lies outside its buffer");
  }
  const auto* root = reinterpret_cast<const Root::DataType*>(bytes.data() + root_offset);
  if (uint64_t(root->mTableSize) * sizeof(Root::Tile) > size - root_offset - sizeof(*root)) {
    return grid_error(field, "its root table runs past the end of its buffer");
  }
  // The checksum reads each level's nodes as one array from the tree's offsets.
  const uint64_t node_bytes[3] = {sizeof(Leaf), sizeof(Lower), sizeof(Upper)};
  for (int level = 0; level < 3; ++level) {
    const uint64_t count = tree->mNodeCount[level];
    if (count == 0) continue;
    const uint64_t begin = sizeof(nanovdb::GridData) + tree->mNodeOffset[level];
    if (begin > size || count > (size - begin) / node_bytes[level]) {
      return grid_error(field,
                        absl::StrCat("its level-", level, " nodes run past the end of its buffer"));
    }
  }
  return absl::OkStatus();
}

const Grid& as_grid(const AlignedBytes& bytes) {
  return *reinterpret_cast<const Grid*>(bytes.data());
}

}  // namespace

absl::Status check_density_grid(const AlignedBytes& bytes, const std::string& field) {
  if (absl::Status header = check_header(bytes, field); !header.ok()) return header;
  const Grid& grid = as_grid(bytes);
  // The bounded walk first: the validator's checksum follows the nodes' offsets unchecked.
  const GridSurvey survey = Surveyor(bytes.data(), bytes.size()).survey(grid);
  if (!survey.problem.empty()) return grid_error(field, survey.problem);
  if (const std::string problem = nanovdb::GridValidator<float>::check(grid, /*detailed=*/true);
      !problem.empty()) {
    return grid_error(field, absl::StrCat("is not a whole NanoVDB grid: ", problem));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<const AlignedBytes>> read_density_grid(
    const std::filesystem::path& path, const std::string& grid_name, const std::string& field) {
  const std::string where = absl::StrCat(field, " (", path.string(), ")");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(where, ": file not found"));
  }
  nanovdb::GridHandle<nanovdb::HostBuffer> handle;
  try {
    if (grid_name.empty()) {
      handle = nanovdb::io::readGrid<nanovdb::HostBuffer>(path.string(), uint64_t{0});
    } else {
      std::vector<std::string> names;
      for (const nanovdb::io::GridMetaData& m : nanovdb::io::readGridMetaData(path.string()))
        names.push_back(m.gridName);
      if (std::find(names.begin(), names.end(), grid_name) == names.end()) {
        return grid_error(where, absl::StrCat("has no grid named '", grid_name,
                                              "' (it holds: ", absl::StrJoin(names, ", "), ")"));
      }
      handle = nanovdb::io::readGrid<nanovdb::HostBuffer>(path.string(), grid_name);
    }
  } catch (const std::exception& e) {
    return grid_error(where, absl::StrCat("cannot be read as a NanoVDB file: ", e.what()));
  }
  if (!handle || handle.size() == 0) return grid_error(where, "holds no grid");
  auto bytes = std::make_shared<AlignedBytes>(handle.size());
  std::memcpy(bytes->data(), handle.data(), handle.size());
  if (absl::Status status = check_density_grid(*bytes, where); !status.ok()) return status;
  return std::shared_ptr<const AlignedBytes>(std::move(bytes));
}

DensityGridFacts density_grid_facts(const AlignedBytes& bytes, const Affine& grid_to_scene) {
  const Grid& grid = as_grid(bytes);
  const GridSurvey survey = Surveyor(bytes.data(), bytes.size()).survey(grid);
  DensityGridFacts facts;
  facts.max_density = survey.max_value;
  facts.active_voxels = survey.active_voxels;
  // The grid's own map from index space to its world, with the placement after it.
  auto index_to_scene = [&](nanovdb::Vec3d i) {
    const nanovdb::Vec3d w = grid.indexToWorld(i);
    return grid_to_scene.apply_to_point(Vec3f(float(w[0]), float(w[1]), float(w[2])));
  };
  if (survey.any_nonzero) {
    // A trilinear sample reads the voxels on both sides: the density reaches a voxel further.
    const nanovdb::Coord lo = survey.nonzero.min(), hi = survey.nonzero.max();
    for (int corner = 0; corner < 8; ++corner) {
      const nanovdb::Vec3d i((corner & 1) ? hi[0] + 1.0 : lo[0] - 1.0,
                             (corner & 2) ? hi[1] + 1.0 : lo[1] - 1.0,
                             (corner & 4) ? hi[2] + 1.0 : lo[2] - 1.0);
      facts.bounds.extend(index_to_scene(i));
    }
  }
  // The scene-to-index map, from the images of the origin and the axes (both maps are affine).
  const Affine scene_to_grid = grid_to_scene.inverse();
  auto scene_to_index = [&](Vec3f p) {
    const Vec3f w = scene_to_grid.apply_to_point(p);
    return grid.worldToIndex(nanovdb::Vec3d(w.x, w.y, w.z));
  };
  const nanovdb::Vec3d o = scene_to_index(Vec3f(0.0f));
  for (int row = 0; row < 3; ++row) facts.scene_to_index[row][3] = float(o[row]);
  for (int axis = 0; axis < 3; ++axis) {
    Vec3f e(0.0f);
    e[axis] = 1.0f;
    const nanovdb::Vec3d i = scene_to_index(e);
    for (int row = 0; row < 3; ++row) facts.scene_to_index[row][axis] = float(i[row] - o[row]);
  }
  float shortest = INFINITY;
  const Vec3f origin = index_to_scene(nanovdb::Vec3d(0.0));
  for (int axis = 0; axis < 3; ++axis) {
    nanovdb::Vec3d e(0.0);
    e[axis] = 1.0;
    shortest = std::min(shortest, length(index_to_scene(e) - origin));
  }
  facts.step = 0.5f * shortest;
  return facts;
}

}  // namespace caustica
