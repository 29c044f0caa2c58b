// Density grids: files NanoVDB wrote read back with their facts, and every broken grid, in a
// file or as bytes from elsewhere, refused with an error that names it.
#include "renderer/scene/density_grid.h"

#include <fstream>

#include "absl/strings/str_format.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/validate.h"
#include "tests/renderer/grid_files.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica::testing {
namespace {

using test_grids::density_grid;
using test_grids::grid_bytes;
using test_grids::write_grid;
using ::testing::HasSubstr;

class DensityGridFiles : public ::testing::Test {
 protected:
  // A scene whose fog is grid `grid` of `file`, placed by `transform` (JSON, or empty).
  absl::StatusOr<Scene> scene_with(const std::string& file, const std::string& grid = "",
                                   const std::string& transform = "") {
    const std::string grid_field = grid.empty() ? "" : absl::StrFormat(R"(, "grid": "%s")", grid);
    const std::string transform_field =
        transform.empty() ? "" : absl::StrFormat(R"(, "transform": %s)", transform);
    return parse_scene(absl::StrFormat(R"({
      "camera": {"position": [0, 0, -5], "look_at": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
      "materials": {"white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
      "media": {"smoke": {"type": "grid", "file": "%s"%s%s,
                          "absorption": [0.1, 0.1, 0.1], "scattering": [1, 1, 1], "g": 0.2}},
      "medium": "smoke",
      "lights": [{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}],
      "shapes": [{"type": "quad", "material": "white",
                  "vertices": [[-4, -2, -4], [4, -2, -4], [4, -2, 4], [-4, -2, 4]]}]
    })",
                                       file, grid_field, transform_field),
                       dir_, "smoke.json");
  }

  test_grids::ScratchDirectory scratch_;
  const std::filesystem::path& dir_ = scratch_.path();
};

// A 16^3 block of density 0.5 with voxels 0.25 wide, voxel (0, 0, 0) centred at (-2, -2, -2).
nanovdb::GridHandle<nanovdb::HostBuffer> block(float value = 0.5f) {
  return density_grid(16, 0.25, nanovdb::Vec3d(-2.0), [=](int, int, int) { return value; });
}

TEST_F(DensityGridFiles, AGridNanoVdbWroteLoadsWithItsFacts) {
  write_grid(dir_ / "smoke.nvdb", block());
  absl::StatusOr<Scene> scene = scene_with("smoke.nvdb", "", R"({"translate": [1, 0, 0]})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Medium& smoke = scene->media.at(0);
  EXPECT_EQ(smoke.type, MediumType::kGrid);
  EXPECT_EQ(smoke.grid_source, "smoke.nvdb");
  ASSERT_NE(smoke.grid, nullptr);
  const DensityGridFacts facts = density_grid_facts(*smoke.grid, smoke.grid_to_scene);
  EXPECT_FLOAT_EQ(facts.max_density, 0.5f);
  EXPECT_EQ(facts.active_voxels, 16u * 16u * 16u);
  EXPECT_FLOAT_EQ(facts.step, 0.125f);
  // Voxel centres run from -2 to 1.75; trilinear samples reach one voxel beyond; the transform
  // moves it all by 1 in x.
  EXPECT_THAT(facts.bounds.lower, Vec3Near(Vec3f(-1.25f, -2.25f, -2.25f), 1e-5f));
  EXPECT_THAT(facts.bounds.upper, Vec3Near(Vec3f(3.0f, 2.0f, 2.0f), 1e-5f));
  // Scene (1, -2, -2) is the grid's (0, -2, -2), voxel (8, 0, 0).
  const auto& m = facts.scene_to_index;
  const Vec3f p(1.0f, -2.0f, -2.0f);
  for (int row = 0; row < 3; ++row) {
    const float index = m[row][0] * p.x + m[row][1] * p.y + m[row][2] * p.z + m[row][3];
    EXPECT_NEAR(index, row == 0 ? 8.0f : 0.0f, 1e-4f) << row;
  }
}

TEST_F(DensityGridFiles, AGridIsPickedByName) {
  auto first = density_grid(
      4, 1.0, nanovdb::Vec3d(0.0), [](int, int, int) { return 1.0f; }, "a");
  auto second = density_grid(
      4, 1.0, nanovdb::Vec3d(0.0), [](int, int, int) { return 3.0f; }, "density");
  std::vector<nanovdb::GridHandle<nanovdb::HostBuffer>> both;
  both.push_back(std::move(first));
  both.push_back(std::move(second));
  nanovdb::io::writeGrids<nanovdb::HostBuffer, std::vector>((dir_ / "two.nvdb").string(), both);
  absl::StatusOr<Scene> scene = scene_with("two.nvdb", "density");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->media[0].grid_source, "two.nvdb (density)");
  EXPECT_FLOAT_EQ(density_grid_facts(*scene->media[0].grid, Affine{}).max_density, 3.0f);

  const absl::Status missing = scene_with("two.nvdb", "temperature").status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(missing),
              HasSubstr("media.smoke.file (" + (dir_ / "two.nvdb").string() +
                        "): has no grid named 'temperature' (it holds: a, density)"));
}

TEST_F(DensityGridFiles, AMissingFileIsNotFoundAndNamed) {
  const absl::Status status = scene_with("nowhere.nvdb").status();
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(status), HasSubstr("smoke.json: media.smoke.file ("));
  EXPECT_THAT(message_of(status), HasSubstr("nowhere.nvdb): file not found"));
}

TEST_F(DensityGridFiles, AFileThatIsNoNanoVdbFileIsRefused) {
  std::ofstream(dir_ / "text.nvdb") << "density 0.5 everywhere\n";
  const absl::Status status = scene_with("text.nvdb").status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(status), HasSubstr("cannot be read as a NanoVDB file"));
}

TEST_F(DensityGridFiles, GridsThatCannotBeDensitiesAreRefused) {
  // A vector grid.
  nanovdb::GridBuilder<nanovdb::Vec3f> vectors(nanovdb::Vec3f(0.0f));
  vectors.getAccessor().setValue(nanovdb::Coord(0), nanovdb::Vec3f(1.0f));
  write_grid(dir_ / "velocity.nvdb", vectors.getHandle<>(1.0, nanovdb::Vec3d(0), "velocity"));
  EXPECT_THAT(message_of(scene_with("velocity.nvdb").status()),
              HasSubstr("is a grid of Vec3f; a density grid holds floats"));
  // A negative density.
  write_grid(dir_ / "negative.nvdb", density_grid(4, 1.0, nanovdb::Vec3d(0.0), [](int i, int, int) {
               return i == 2 ? -0.5f : 1.0f;
             }));
  EXPECT_THAT(message_of(scene_with("negative.nvdb").status()),
              HasSubstr("holds the value -0.5; a density is finite and >= 0"));
  // A background that fills all space.
  write_grid(dir_ / "background.nvdb", density_grid(
                                           4, 1.0, nanovdb::Vec3d(0.0),
                                           [](int, int, int) { return 2.0f; }, "density", 0.25f));
  EXPECT_THAT(message_of(scene_with("background.nvdb").status()),
              HasSubstr("the background value is 0.25"));
}

TEST_F(DensityGridFiles, ASingularTransformIsRefused) {
  write_grid(dir_ / "smoke.nvdb", block());
  Scene scene = *scene_with("smoke.nvdb");
  scene.media[0].grid_to_scene = scaling(Vec3f(1.0f, 0.0f, 1.0f));
  EXPECT_THAT(message_of(validate_scene(scene)),
              HasSubstr("media.smoke.transform: is not an invertible map"));
}

// Bytes from elsewhere (the wire): each kind of damage is named, and nothing past the buffer is
// read on the way.
TEST(DensityGridBytes, DamagedBuffersAreRefusedWithTheirProblem) {
  const auto handle = block();
  const std::shared_ptr<const AlignedBytes> good = grid_bytes(handle);
  EXPECT_TRUE(check_density_grid(*good, "media.smoke.grid").ok());

  auto damaged = [&](auto&& damage) {
    auto bytes = std::make_shared<AlignedBytes>(good->size());
    std::memcpy(bytes->data(), good->data(), good->size());
    damage(*bytes);
    return message_of(check_density_grid(*bytes, "media.smoke.grid"));
  };
  EXPECT_THAT(damaged([](AlignedBytes& b) { b.data()[0] ^= 0xff; }),
              HasSubstr("media.smoke.grid: is not a NanoVDB grid"));
  // The grid's name changed: the checksum over its header no longer matches.
  EXPECT_THAT(damaged([](AlignedBytes& b) {
                reinterpret_cast<nanovdb::GridData*>(b.data())->mGridName[0] ^= 0x20;
              }),
              HasSubstr("is not a whole NanoVDB grid: Mis-matching checksum"));
  // A voxel made negative.
  EXPECT_THAT(damaged([](AlignedBytes& b) {
                auto* grid = reinterpret_cast<nanovdb::NanoGrid<float>*>(b.data());
                grid->tree().getFirstLeaf()->data()->mValues[3] = -1.0f;
              }),
              HasSubstr("holds the value -1"));
  // A root that claims more tiles than the buffer holds.
  EXPECT_THAT(damaged([](AlignedBytes& b) {
                auto* grid = reinterpret_cast<nanovdb::NanoGrid<float>*>(b.data());
                grid->tree().root().data()->mTableSize = 1u << 30;
              }),
              HasSubstr("its root table runs past the end of its buffer"));
  // Another NanoVDB major version: named as numbers (its c_str() leaked a string per grid).
  EXPECT_THAT(
      damaged([](AlignedBytes& b) {
        reinterpret_cast<nanovdb::GridData*>(b.data())->mVersion =
            nanovdb::Version(NANOVDB_MAJOR_VERSION_NUMBER + 7, 4, 2);
      }),
      HasSubstr(absl::StrFormat("was written by NanoVDB %d.4.2; this build reads version %d.x",
                                NANOVDB_MAJOR_VERSION_NUMBER + 7, NANOVDB_MAJOR_VERSION_NUMBER)));
  // A grid type past the end of NanoVDB's table of type names, which must not be indexed with it.
  EXPECT_THAT(damaged([](AlignedBytes& b) {
                reinterpret_cast<nanovdb::GridData*>(b.data())->mGridType =
                    static_cast<nanovdb::GridType>(4000);
              }),
              HasSubstr("is a grid of unknown type 4000; a density grid holds floats"));
  EXPECT_THAT(damaged([](AlignedBytes& b) {
                reinterpret_cast<nanovdb::GridData*>(b.data())->mGridType =
                    nanovdb::GridType::Double;
              }),
              HasSubstr("is a grid of double; a density grid holds floats"));
  // Too short to be anything, and shorter than the grid says.
  EXPECT_THAT(message_of(check_density_grid(AlignedBytes(64), "g")), HasSubstr("too few"));
  AlignedBytes truncated(good->size() - 32);
  std::memcpy(truncated.data(), good->data(), truncated.size());
  EXPECT_THAT(message_of(check_density_grid(truncated, "g")),
              HasSubstr(absl::StrFormat("says it is %d bytes long but %d bytes arrived",
                                        good->size(), truncated.size())));
}

}  // namespace
}  // namespace caustica::testing
