// caustica-bench: prints one JSON line per measured figure, or with --soak one line of a soak
// test's results.
#include <CLI/CLI.hpp>
#include <iostream>

#include "absl/strings/str_join.h"
#include "bench/benchmarks.h"
#include "bench/soak.h"
#include "proto/wire/frame_heap.h"
#include "tools/cli/setting_names.h"
#include "tools/cli/structure_option.h"

int main(int argc, char** argv) {
  caustica::wire::keep_frame_buffers();
  caustica::BenchOptions options;
  caustica::SoakOptions soak;
  CLI::App app{
      "Benchmarks of the Caustica renderer stages; one JSON line per figure.\n"
      "With --soak, a soak test of caustica-server instead: --clients clients cycle upload, light "
      "change, render, stream, cancelled stream and delete for --minutes after --warmup-minutes "
      "of warm-up, then --storm streams are opened and cancelled at once. One JSON line reports "
      "per-call latency and errors (every frame is compared with one rendered at the start), the "
      "server's memory at the start and the end, and \"pass\"; the exit status is 2 when it "
      "did not pass. With --hostile, every client also attacks every port of the server between "
      "its cycles. --scene, --width, --height, --photons and --device apply to it (default: "
      "the bundled Cornell box at 64x64 with 1000 photons on a cpu server)."};
  app.add_option(
      "--mesh", options.mesh,
      "triangle mesh (.ply, .ply.gz, .obj, .gltf, .glb) for the structure and ray benchmarks");
  app.add_option("--copies", options.copies,
                 "instances of the mesh, copy i shifted by i*(0.25,0.15,0)")
      ->check(CLI::Range(1, 64));
  app.add_option("--scene", options.photon_scene, "scene file for the photon and frame benchmarks");
  app.add_option("--only", options.only,
                 "run only these benchmarks: " + absl::StrJoin(caustica::benchmark_names(), ", "));
  app.add_option("--runs", options.runs, "measured runs per figure (median reported)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--warmup", options.warmup, "unmeasured runs first")->check(CLI::Range(0, 100));
  app.add_option("--width", options.width, "image width for ray and frame benchmarks")
      ->check(CLI::Range(1, 16384));
  app.add_option("--height", options.height, "image height for ray and frame benchmarks")
      ->check(CLI::Range(1, 16384));
  app.add_option("--photons", options.photons, "photons per photon pass");
  app.add_option("--k", options.k, "photons per radiance estimate in the frame benchmark");
  app.add_option("--estimator", options.estimator,
                 "the frame benchmarks' estimator: knn, sppm or vkde (the convergence benchmark "
                 "runs each)")
      ->type_name("NAME")
      ->transform(caustica::estimator_names());
  app.add_flag("--final-gather", options.final_gather,
               "the frame benchmarks' knn estimator gathers its indirect light by final gathering");
  app.add_option("--final-gather-rays", options.final_gather_rays,
                 "final gathering's rays a seed (default: the scene's)")
      ->check(CLI::Range(1, 65536));
  app.add_option("--final-gather-seeds", options.final_gather_seeds,
                 "final gathering's seeds a pass (default: the scene's)")
      ->check(CLI::Range(1, 1 << 24));
  app.add_option("--photons-per-leaf", options.photons_per_leaf,
                 "photons per leaf of the photon maps' hierarchy (with vkde, kernels per leaf); 0 "
                 "(the default) takes what the engine takes for the device and --k (vkde: "
                 "Fabianowski's n_auto)")
      ->check(CLI::Range(0, 256));
  app.add_option("--device", options.device,
                 "backend to measure; the serving benchmarks pass it to the server they start")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  app.add_option(
         "--devices", options.devices,
         "frame_devices, animation_devices: the GPUs (ordinals, repeats allowed: 0,0 is two "
         "backends on GPU 0) or, with --device cpu, one CPU backend per "
         "entry; default every GPU, or 0,0 where there is one")
      ->delimiter(',')
      ->check(CLI::Range(0, 63));
  std::vector<std::string> structures;
  app.add_option("--structure", structures,
                 "triangle structures to measure, each in turn: all, or any of " +
                     caustica::structure_kind_list() + " (default " +
                     caustica::structure_kind_name(caustica::kDefaultStructure) + ")")
      ->check([](const std::string& name) -> std::string {
        if (name == "all" || caustica::parse_structure_kind(name)) return "";
        return caustica::unknown_structure_message(name, "all, ");
      });
  app.add_option("--structure-option", options.structure_options, caustica::kStructureOptionHelp)
      ->type_name("NAME=VALUE")
      ->check(caustica::structure_option_check());
  app.add_option("--reference-passes", options.reference_passes,
                 "convergence: passes of the path-traced reference")
      ->check(CLI::Range(1, 1 << 20));
  app.add_option("--convergence-passes", options.convergence_passes,
                 "convergence: the most passes each integrator runs (doubling from 1)")
      ->check(CLI::Range(1, 1 << 20));
  app.add_option("--convergence-run", options.convergence_runs,
                 "convergence: measure only these runs (repeatable): " +
                     absl::StrJoin(caustica::convergence_run_names(), ", "))
      ->type_name("NAME")
      ->check(CLI::IsMember(caustica::convergence_run_names()));
  app.add_option("--branch-survival", options.branch_survival,
                 "frame_render: the most a deep camera branch survives Russian roulette with (0 "
                 "ends every branch at depth 6; default: the renderer's)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--kernels", options.kernels,
               "after each measured benchmark, print its launches' times: one JSON line per "
               "launch name with launches and milliseconds per run, the most time first");
  app.add_flag(
      "--ray-queues", options.ray_queues,
      "photon and frame benchmarks: trace through the ray queues (batches of closest and "
      "any hits) even for structures that answer single rays, as batch-only ones always do");
  app.add_option("--seed-scenes", options.seed_scenes,
                 "seed_tables: the folder of the bundled scenes (default: the source tree's "
                 "scenes/)");
  app.add_option("--dragon", options.dragon,
                 "seed_tables: the Stanford dragon's mesh (scripts/fetch-dragon); without it the "
                 "dragon's rows are listed as unavailable");
  app.add_option("--flight-frames", options.flight_frames,
                 "seed_tables: the frames of each flight measured (default: all)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--seed-reduce", options.seed_reduce,
                 "seed_tables: every table's image sides and photons divided by this, for a quick "
                 "look (default 1: the seeds' own)")
      ->check(CLI::Range(1, 1024));
  bool soak_mode = false;
  CLI::Option* soak_flag = app.add_flag("--soak", soak_mode, "run the soak test (see above)");
  app.add_option("--clients", soak.clients, "soak: concurrent clients")
      ->check(CLI::Range(1, 1024))
      ->needs(soak_flag)
      ->capture_default_str();
  app.add_option("--minutes", soak.minutes,
                 "soak: minutes of measured cycling after the warm-up (fractions allowed)")
      ->check(CLI::NonNegativeNumber)
      ->needs(soak_flag)
      ->capture_default_str();
  app.add_option("--warmup-minutes", soak.warmup_minutes,
                 "soak: minutes of unmeasured cycling first (and --warmup-cycles per client at "
                 "least), so that the start's memory is the server's steady state")
      ->check(CLI::NonNegativeNumber)
      ->needs(soak_flag)
      ->capture_default_str();
  app.add_option("--warmup-cycles", soak.warmup_cycles,
                 "soak: cycles each client makes in the warm-up at least, however long they take "
                 "(a slow build, a sanitizer's, reaches fewer in --warmup-minutes)")
      ->check(CLI::Range(1, 1000000))
      ->needs(soak_flag)
      ->capture_default_str();
  app.add_option("--storm", soak.storm,
                 "soak: streams opened and cancelled at once at the end (0: no storm)")
      ->check(CLI::Range(0, 4096))
      ->needs(soak_flag)
      ->capture_default_str();
  CLI::Option* server =
      app.add_option(
             "--server", soak.server,
             "soak: host:port of a running server to soak instead of starting one (it needs "
             "--max-scenes of at least --clients + 2 free)")
          ->needs(soak_flag);
  app.add_option("--server-pid", soak.server_pid,
                 "soak: the process id of the --server, whose resident memory is then reported")
      ->check(CLI::PositiveNumber)
      ->needs(server);
  app.add_option("--data-dir", soak.data_dir,
                 "soak: the started server keeps scenes in this directory (--data-dir), so the "
                 "soak covers storing them too; default: none")
      ->needs(soak_flag)
      ->excludes(server);
  app.add_flag("--hostile", soak.hostile,
               "soak: between its cycles every client also sends what no well-behaved client "
               "sends, one class in turn: hostile strings in every field of a call, truncated, "
               "garbage and oversized bytes on every port, WebSocket messages over the limit and "
               "bad viewer tokens, slow and idle connections, and calls dropped midway. The "
               "started server opens its health, metrics and viewer ports too; \"pass\" then also "
               "needs every hostile probe answered as promised and every port answering within a "
               "second after the storm")
      ->needs(soak_flag)
      ->excludes(server);
  app.add_option("--deadline", soak.deadline_s, "soak: seconds every call may take")
      ->check(CLI::PositiveNumber)
      ->needs(soak_flag)
      ->capture_default_str();
  bool print_camera = false;
  app.add_flag("--print-camera", print_camera,
               "print the ray benchmarks' camera for --mesh (position look_at up fov) and exit");
  CLI11_PARSE(app, argc, argv);
  if (soak_mode) {
    soak.scene = options.photon_scene;
    soak.device = options.device;
    if (app.count("--width")) soak.width = options.width;
    if (app.count("--height")) soak.height = options.height;
    if (app.count("--photons")) soak.photons = options.photons;
    absl::StatusOr<bool> passed = caustica::run_soak(soak, std::cout);
    if (!passed.ok()) {
      std::cerr << "caustica-bench: soak: " << passed.status().message() << "\n";
      return 1;
    }
    return *passed ? 0 : 2;
  }
  if (!structures.empty()) {
    options.structures.clear();
    for (const std::string& name : structures) {
      if (name == "all") {
        options.structures.assign(std::begin(caustica::kStructureKinds),
                                  std::end(caustica::kStructureKinds));
        break;
      }
      options.structures.push_back(*caustica::parse_structure_kind(name));
    }
  }

  absl::Status status = print_camera ? caustica::print_ray_camera(options, std::cout)
                                     : caustica::run_benchmarks(options, std::cout);
  if (!status.ok()) {
    std::cerr << "caustica-bench: " << status.message() << "\n";
    return 1;
  }
  return 0;
}
