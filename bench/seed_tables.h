// The seeds' published tables reproduced row by row on this device (--only seed_tables;
// docs/seeds.md): each row's figure as the seed printed it, ours, and the speed-up between them.
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "bench/benchmarks.h"

namespace caustica {

class Reporter;

// The tables, in the order seed_tables measures them.
std::vector<std::string> seed_table_names();

// Fabianowski's Table 6.6 (frames under dynamic illumination over each scene's flight), Zeidan's
// Tables 4.3-4.9 (structure builds, primary ray casts and SAH costs) and Ravichandran and
// Narayanan's Tables 1 and 2 (DACRT's construct-and-trace of primary, shadow, specular and
// ambient-occlusion rays). Scenes come from o.seed_scenes; a row whose scene is not there (or
// never was published) is one line saying so.
absl::Status seed_tables(const BenchOptions& o, Reporter& report);

}  // namespace caustica
