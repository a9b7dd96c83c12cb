// The hrad subcommands. main.cpp parses the command line (the only file that
// includes CLI11, whose headers are slow to compile) into Params and calls
// one of these. Each returns the process exit code.
#pragma once

#include <string>

#include "core/params.h"

namespace hrad::app {

struct SolveOptions {
    std::string scene;
    std::string outDir = "out";
    int threads = 0;  ///< 0: all cores
    bool progress = true;
    bool writeImages = true;
    bool writePly = true;
};

/// `hrad info SCENE`: counts, area, power, bounds, materials, load time.
int runInfo(const std::string& scene, Params& params);

/// `hrad solve SCENE ...`: solve and write image.exr, image.png, solution.ply,
/// summary.json into the output folder.
int runSolve(const SolveOptions& options, Params& params);

}  // namespace hrad::app
