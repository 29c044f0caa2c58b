// What a structure's builder is told besides its kind (settings.build): the stages of binned-sah's
// data-parallel levels (hybrid's too, below its cut) and how a level puts triangles in bin order,
// and how a kd-tree is walked. A scene carries them in RenderSettings, the scene file's
// settings.build, the proto's BuildOptions and the CLI's --structure-option, and SceneInfo reports
// them back; build_structure hands each builder its own and the others ignore them. A leaf header,
// as structure_kind.h is, so that the scene model carries the options without depending on the
// builders.
#pragma once

#include <charconv>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "renderer/accel/structure_kind.h"
#include "renderer/base/hd.h"
#include "renderer/scene/setting_kinds.h"

namespace caustica {

constexpr int kMaxBinnedSahStages = 6;
constexpr uint32_t kMaxBinnedSahBins = 128;
// An ABOVE beyond this is no limit a triangle count reaches.
constexpr uint32_t kMaxBinnedSahAbove = 1u << 31;

// A stage of the data-parallel levels: the nodes of more than `above` triangles (and no more than
// the previous stage's `above`) bin their centroids into `bins` bins.
struct BinnedSahStage {
  uint32_t above = 0;
  uint32_t bins = 0;
  bool operator==(const BinnedSahStage&) const = default;
};

// How a level puts every node's triangles in bin order: one radix sort of (node, bin) keys over
// all of them, or a stable split of each node's triangles per bit of the bin, a scan each. Both
// build the same tree (binned_sah.h).
enum class BinnedSahReorder : uint8_t { kRadixSort = 0, kSegmentedSplits = 1 };
template <>
struct SettingKinds<BinnedSahReorder> {
  static constexpr const char* what = "binned-sah reorder";
  static constexpr SettingKind<BinnedSahReorder> kinds[] = {
      {BinnedSahReorder::kRadixSort, "sort", 1}, {BinnedSahReorder::kSegmentedSplits, "split", 2}};
};

// The stages, largest nodes first. The last stage's `above` is the per-node limit: nodes within
// it go to the per-node stage. A plain value, copied into kernels; the default is the schedule
// chosen by measurement (docs/structures.md, "binned-sah: the stages"). Unused stages stay zero,
// so that the defaulted comparison compares schedules.
struct BinnedSahSchedule {
  BinnedSahStage stage[kMaxBinnedSahStages] = {{64, 16}};
  int stage_count = 1;
  BinnedSahReorder reorder = BinnedSahReorder::kRadixSort;

  // The bins of a node of `size` triangles, or 0 when the per-node stage splits it.
  CAUSTICA_HDI uint32_t bins_for(uint32_t size) const {
    for (int i = 0; i < stage_count; ++i)
      if (size > stage[i].above) return stage[i].bins;
    return 0;
  }
  CAUSTICA_HDI uint32_t per_node_limit() const { return stage[stage_count - 1].above; }
  uint32_t max_bins() const {
    uint32_t most = 0;
    for (int i = 0; i < stage_count; ++i) most = stage[i].bins > most ? stage[i].bins : most;
    return most;
  }
  bool operator==(const BinnedSahSchedule&) const = default;
};

// How closest_hit and any_hit walk a kd-tree (kd_traversal.h).
enum class KdTraversal : uint32_t {
  kStack = 0,      // front to back with a stack of (node, interval end)
  kStackless = 1,  // Fabianowski's flags-register restart, with push-down and a short stack
};
template <>
struct SettingKinds<KdTraversal> {
  static constexpr const char* what = "kd-tree traversal";
  static constexpr SettingKind<KdTraversal> kinds[] = {{KdTraversal::kStack, "stack", 1},
                                                       {KdTraversal::kStackless, "stackless", 2}};
};

// What a geometry change does to a structure that can be refitted (refits, structure_kind.h):
// kAuto refits it (its boxes recomputed bottom-up over the moved triangles, its topology kept)
// while the refitted SAH cost stays within refit_sah_bound times the cost it had when last built,
// and builds it anew otherwise; kAlways refits it whatever its cost; kNever builds it anew. A
// structure that cannot be refitted is built anew under every policy. docs/dynamic.md says which.
enum class RefitPolicy : uint8_t { kAuto = 0, kAlways = 1, kNever = 2 };
template <>
struct SettingKinds<RefitPolicy> {
  static constexpr const char* what = "refit policy";
  static constexpr SettingKind<RefitPolicy> kinds[] = {{RefitPolicy::kAuto, "auto", 1},
                                                       {RefitPolicy::kAlways, "always", 2},
                                                       {RefitPolicy::kNever, "never", 3}};
};
constexpr float kDefaultRefitSahBound = 1.5f;
constexpr float kMaxRefitSahBound = 1000.0f;

struct BuildOptions {
  BinnedSahSchedule binned_sah;                    // binned-sah, and hybrid below its cut
  KdTraversal kd_traversal = KdTraversal::kStack;  // kd-sah and kd-siroh
  RefitPolicy refit = RefitPolicy::kAuto;          // lbvh4, binned-sah and hybrid
  float refit_sah_bound = kDefaultRefitSahBound;   // >= 1: kAuto's bound
  bool operator==(const BuildOptions&) const = default;
};

// The options a structure of `kind` reads when it is built, every other at its default: two
// settings build the same structure when their kinds agree and so do these, whatever the options
// other kinds read. The refit policy is not among them: it decides what a geometry change does,
// never how a build goes.
inline BuildOptions options_read_by(StructureKind kind, const BuildOptions& options) {
  BuildOptions read;
  switch (kind) {
    case StructureKind::kBinnedSah:
    case StructureKind::kHybrid:
      read.binned_sah = options.binned_sah;
      break;
    case StructureKind::kKdSah:
    case StructureKind::kKdSiroh:
      read.kd_traversal = options.kd_traversal;
      break;
    default:
      break;
  }
  return read;
}

// The first problem of stage `index` (0-based) after stages [0, index) were accepted, as
// "stage 2 ('4096:256'): BINS must be within [2, 128]"; nullopt for a good stage.
inline std::optional<std::string> binned_sah_stage_problem(const BinnedSahStage* stages,
                                                           int index) {
  const BinnedSahStage& s = stages[index];
  const std::string name = "stage " + std::to_string(index + 1) + " ('" + std::to_string(s.above) +
                           ":" + std::to_string(s.bins) + "')";
  if (s.bins < 2 || s.bins > kMaxBinnedSahBins)
    return name + ": BINS must be within [2, " + std::to_string(kMaxBinnedSahBins) + "]";
  if (s.above > kMaxBinnedSahAbove) return name + ": ABOVE must be at most 2^31";
  if (s.above < s.bins)
    return name + ": ABOVE must be at least BINS, so that a node has more triangles than bins";
  if (index > 0 && s.above >= stages[index - 1].above)
    return name + ": ABOVE must be below the previous stage's " +
           std::to_string(stages[index - 1].above);
  return std::nullopt;
}

// The first problem of a schedule's stages from outside (a scene, the wire); nullopt for good ones.
inline std::optional<std::string> binned_sah_stages_problem(const BinnedSahSchedule& schedule) {
  if (schedule.stage_count < 1)
    return std::string("no stages (at least one ABOVE:BINS, largest nodes first)");
  if (schedule.stage_count > kMaxBinnedSahStages)
    return "at most " + std::to_string(kMaxBinnedSahStages) + " stages";
  for (int i = 0; i < schedule.stage_count; ++i)
    if (std::optional<std::string> problem = binned_sah_stage_problem(schedule.stage, i))
      return problem;
  return std::nullopt;
}

// The stages from their text, "ABOVE:BINS,ABOVE:BINS,...", largest nodes first, into `schedule`
// (its reorder kept); the first problem, naming the stage, when the text is no good schedule.
inline std::optional<std::string> parse_binned_sah_stages(std::string_view text,
                                                          BinnedSahSchedule& schedule) {
  if (text.empty()) return std::string("none given (ABOVE:BINS,...)");
  BinnedSahSchedule parsed;
  parsed.stage[0] = {};
  parsed.stage_count = 0;
  parsed.reorder = schedule.reorder;
  while (true) {
    const size_t comma = text.find(',');
    const std::string_view entry = text.substr(0, comma);
    const std::string name =
        "stage " + std::to_string(parsed.stage_count + 1) + " ('" + std::string(entry) + "')";
    if (parsed.stage_count == kMaxBinnedSahStages)
      return name + ": at most " + std::to_string(kMaxBinnedSahStages) + " stages";
    const size_t colon = entry.find(':');
    if (colon == std::string_view::npos) return name + ": expected ABOVE:BINS";
    uint32_t numbers[2] = {};
    const std::string_view parts[2] = {entry.substr(0, colon), entry.substr(colon + 1)};
    const char* part_names[2] = {"ABOVE", "BINS"};
    for (int p = 0; p < 2; ++p) {
      const std::string_view part = parts[p];
      const auto [end, error] = std::from_chars(part.data(), part.data() + part.size(), numbers[p]);
      if (part.empty() || error != std::errc() || end != part.data() + part.size() ||
          numbers[p] > kMaxBinnedSahAbove)
        return name + ": " + part_names[p] + " '" + std::string(part) +
               "' is not a whole number of at most 2^31";
    }
    parsed.stage[parsed.stage_count] = {numbers[0], numbers[1]};
    if (std::optional<std::string> problem =
            binned_sah_stage_problem(parsed.stage, parsed.stage_count))
      return problem;
    ++parsed.stage_count;
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  schedule = parsed;
  return std::nullopt;
}

// "ABOVE:BINS,...", the text parse_binned_sah_stages reads.
inline std::string binned_sah_stages_text(const BinnedSahSchedule& schedule) {
  std::string text;
  for (int i = 0; i < schedule.stage_count; ++i) {
    if (i > 0) text += ',';
    text += std::to_string(schedule.stage[i].above) + ':' + std::to_string(schedule.stage[i].bins);
  }
  return text;
}

// The problem of a refit bound from outside (a scene, the wire); nullopt for a good one.
inline std::optional<std::string> refit_sah_bound_problem(float bound) {
  if (!(bound >= 1.0f && bound <= kMaxRefitSahBound))
    return std::string("must be within [1, 1000]: the refitted cost over the built one");
  return std::nullopt;
}

// One option as the command line names it, NAME=VALUE with NAME one of binned-sah-stages,
// binned-sah-reorder, kd-traversal, refit or refit-sah-bound, applied to `options`; the problem,
// naming the option, otherwise.
inline std::optional<std::string> apply_structure_option(std::string_view option,
                                                         BuildOptions& options) {
  const size_t equals = option.find('=');
  // Appended rather than "'" + std::string(...), which g++ 12 warns about (a false -Wrestrict).
  auto quoted = [](std::string_view text, const char* problem) {
    std::string message = "'";
    message.append(text).append("'").append(problem);
    return message;
  };
  if (equals == std::string_view::npos)
    return quoted(option,
                  ": expected NAME=VALUE (binned-sah-stages, binned-sah-reorder, kd-traversal, "
                  "refit or refit-sah-bound)");
  const std::string_view name = option.substr(0, equals);
  const std::string_view value = option.substr(equals + 1);
  if (name == "binned-sah-stages") {
    if (std::optional<std::string> problem = parse_binned_sah_stages(value, options.binned_sah))
      return "binned-sah-stages: " + *problem;
    return std::nullopt;
  }
  if (name == "binned-sah-reorder") {
    const std::optional<BinnedSahReorder> reorder = parse_kind<BinnedSahReorder>(value);
    if (!reorder) return "binned-sah-reorder: " + unknown_kind_message<BinnedSahReorder>(value);
    options.binned_sah.reorder = *reorder;
    return std::nullopt;
  }
  if (name == "kd-traversal") {
    const std::optional<KdTraversal> traversal = parse_kind<KdTraversal>(value);
    if (!traversal) return "kd-traversal: " + unknown_kind_message<KdTraversal>(value);
    options.kd_traversal = *traversal;
    return std::nullopt;
  }
  if (name == "refit") {
    const std::optional<RefitPolicy> policy = parse_kind<RefitPolicy>(value);
    if (!policy) return "refit: " + unknown_kind_message<RefitPolicy>(value);
    options.refit = *policy;
    return std::nullopt;
  }
  if (name == "refit-sah-bound") {
    float bound = 0;
    const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), bound);
    if (value.empty() || error != std::errc() || end != value.data() + value.size())
      return "refit-sah-bound: '" + std::string(value) + "' is not a number";
    if (std::optional<std::string> problem = refit_sah_bound_problem(bound))
      return "refit-sah-bound: " + *problem;
    options.refit_sah_bound = bound;
    return std::nullopt;
  }
  return quoted(name,
                " is not a structure option (expected binned-sah-stages, binned-sah-reorder, "
                "kd-traversal, refit or refit-sah-bound)");
}

// `given` options (NAME=VALUE each, checked before, as the command-line tools check them) in
// order over `options`; one with a problem changes nothing.
inline BuildOptions apply_structure_options(const std::vector<std::string>& given,
                                            BuildOptions options) {
  for (const std::string& option : given) (void)apply_structure_option(option, options);
  return options;
}

// The shortest text that reads back as `value` ("1.5", not "1.500000").
inline std::string shortest_float_text(float value) {
  char text[32];
  const auto [end, error] = std::to_chars(text, text + sizeof(text), value);
  return error == std::errc() ? std::string(text, end) : std::to_string(value);
}

// The options as --structure-option and `caustica scene info` show them.
inline std::string build_options_text(const BuildOptions& options) {
  return "binned-sah-stages=" + binned_sah_stages_text(options.binned_sah) +
         " binned-sah-reorder=" + kind_name(options.binned_sah.reorder) +
         " kd-traversal=" + kind_name(options.kd_traversal) + " refit=" + kind_name(options.refit) +
         " refit-sah-bound=" + shortest_float_text(options.refit_sah_bound);
}

}  // namespace caustica
