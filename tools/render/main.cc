// caustica-render: renders a scene file locally on the CPU backend and writes an image.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdint>
#include <iostream>
#include <optional>
#include <string>

#include "tools/cli/setting_names.h"
#include "tools/cli/structure_option.h"
#include "tools/render/render_job.h"

int main(int argc, char** argv) {
  caustica::RenderJob job;
  CLI::App app{"Render a Caustica scene file with photon-mapped global illumination."};
  app.add_option("scene", job.scene, "scene file (JSON, see docs/scene-format.md)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--output", job.output,
                 "output image: .png/.jpg (tone-mapped sRGB) or .exr/.pfm (linear)")
      ->required();
  app.add_option("--width", job.width, "image width in pixels (default: the scene's camera)");
  app.add_option("--height", job.height, "image height in pixels (default: the scene's camera)");
  app.add_option("--photons", job.photons, "photons emitted per pass");
  app.add_option("--k", job.k, "photons per radiance estimate (k nearest)");
  app.add_option("--passes", job.passes, "progressive passes, fresh photons each");
  app.add_option("--seed", job.seed, "random seed; the same seed gives the same image");
  app.add_option("--structure", job.structure,
                 "ray-tracing structure: " + caustica::structure_kind_list() +
                     " (default: the scene's, else " +
                     caustica::structure_kind_name(caustica::kDefaultStructure) + ")")
      ->type_name("NAME")
      ->transform(caustica::structure_names());
  app.add_option("--structure-option", job.structure_options,
                 std::string(caustica::kStructureOptionHelp) + " (default: the scene's)")
      ->type_name("NAME=VALUE")
      ->check(caustica::structure_option_check());
  app.add_option("--integrator", job.integrator,
                 "photon (photon-mapped global illumination) or path (the unbiased path-traced "
                 "reference) (default: the scene's, else photon)")
      ->type_name("NAME")
      ->transform(caustica::integrator_names());
  app.add_option("--estimator", job.estimator,
                 "knn (the k nearest photons), sppm (progressive, converging) or vkde "
                 "(variable kernels from photon differentials) (default: the scene's, else knn)")
      ->type_name("NAME")
      ->transform(caustica::estimator_names());
  app.add_option("--final-gather", job.final_gather,
                 "true or false: the knn estimator's indirect light by final gathering from "
                 "adaptively seeded points (default: the scene's, else false)")
      ->type_name("BOOL");
  app.add_option("--exposure", job.exposure_stops, "exposure in stops for 8-bit outputs");
  CLI11_PARSE(app, argc, argv);
  job.show_progress = isatty(STDERR_FILENO);

  auto summary = caustica::run_render_job(job, std::cout);
  if (!summary.ok()) {
    std::cerr << "caustica-render: " << summary.status().message() << "\n";
    return 1;
  }
  return 0;
}
