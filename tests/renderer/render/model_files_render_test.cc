// Every model file of tests/data/scene (other tools' exporter output and our own) opened as a bare
// model, the way `caustica render MODEL` opens it: each either renders, with finite pixels and
// some light on the model, or is refused with a message that names the file. None may crash.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> model_files() {
  // Sidecar files (.bin buffers, .mtl materials) are read through the model that names them.
  const std::set<std::string> models = {".obj", ".ply", ".gltf", ".glb", ".fbx",
                                        ".dae", ".stl", ".3mf",  ".off"};
  std::vector<fs::path> files;
  for (const char* dir : {"scene/thirdparty", "scene/meshes", "scene/bad"}) {
    const fs::path root = fs::path(CAUSTICA_TEST_DATA) / dir;
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(root)) {
      if (entry.is_regular_file() && models.count(entry.path().extension().string()) != 0) {
        files.push_back(entry.path());
      }
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ModelFiles, EveryOneRendersOrIsRefusedByName) {
  const std::vector<fs::path> files = model_files();
  ASSERT_GE(files.size(), 20u);
  int rendered = 0, refused = 0;
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    absl::StatusOr<Scene> scene = load_scene(file);
    if (!scene.ok()) {
      ++refused;
      EXPECT_NE(std::string(scene.status().message()).find(file.filename().string()),
                std::string::npos)
          << scene.status();
      continue;
    }
    scene->camera.width = 16;
    scene->camera.height = 12;
    scene->settings.photons_per_pass = 2000;
    auto engine = engine_with(*scene);
    ASSERT_TRUE(engine->render(1).ok());
    double sum = 0;
    for (float v : engine->image_linear()) {
      ASSERT_TRUE(std::isfinite(v));
      sum += v;
    }
    EXPECT_GT(sum, 0) << "the framed model is lit";
    ++rendered;
  }
  EXPECT_GT(rendered, 15);
  EXPECT_GT(refused, 3);
  std::printf("%d model files rendered, %d refused by name\n", rendered, refused);
}

}  // namespace
}  // namespace caustica
