// shape-slam: command-line front end of ShapeSLAM. Dispatches to one sub-command per file.
#include <exception>
#include <iostream>
#include <string>

#include "app_common.h"
#include "cli.h"
#include "commands.h"

namespace {

using shape_slam::app::Args;

struct Command {
  const char* name;
  int (*run)(const Args&);
  const char* summary;
};

const Command kCommands[] = {
    {"run", shape_slam::app::RunRun, "build a polyline map from a log (the main job)"},
    {"localize", shape_slam::app::RunLocalize,
     "localization of a log in a saved map.polylines (the map is unchanged)"},
    {"extract", shape_slam::app::RunExtract,
     "polylines of one scan before and after Discrete Curve Evolution"},
    {"match", shape_slam::app::RunMatch,
     "pose of one scan in the frame of another, by shape, with no guess needed"},
    {"eval", shape_slam::app::RunEval, "ATE and relation errors against reference poses"},
    {"convert", shape_slam::app::RunConvert, "CARMEN log to an MRPT rawlog"},
};

void PrintHelp(std::ostream& out) {
  out << "Usage: shape-slam <command> [options]\n\n"
         "ShapeSLAM: 2D laser SLAM on shape (polylines, Discrete Curve Evolution, shape\n"
         "similarity), after Wolter & Latecki, \"Shape-Based Robot Mapping\".\n\n"
         "Commands:\n";
  for (const Command& command : kCommands) {
    out << "  " << command.name << std::string(10 - std::string(command.name).size(), ' ')
        << command.summary << "\n";
  }
  out << "  version   print the version (also --version)\n";
  out << "\nLogs: CARMEN (.log, .clf, optionally .gz) and MRPT rawlogs (.rawlog, gzip or plain).\n"
         "Run 'shape-slam <command> --help' for the options of a command.\n";
}

}  // namespace

int main(int argc, char** argv) {
  shape_slam::app::InstallFatalSignalHandlers();
  if (argc < 2) {
    PrintHelp(std::cerr);
    return 2;
  }
  const std::string name = argv[1];
  if (name == "-h" || name == "--help" || name == "help") {
    PrintHelp(std::cout);
    return 0;
  }
  if (name == "--version" || name == "version") {
    std::cout << "shape-slam " << SHAPE_SLAM_VERSION << "\n";
    return 0;
  }
  const Args args(argv + 2, argv + argc);
  for (const Command& command : kCommands) {
    if (name != command.name) continue;
    shape_slam::app::SetFatalContext("running 'shape-slam " + name + "'");
    try {
      return command.run(args);
    } catch (const shape_slam::app::UsageError& e) {
      std::cerr << "shape-slam " << name << ": " << e.what() << "\n"
                << "Try 'shape-slam " << name << " --help'.\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "shape-slam " << name << ": error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "shape-slam: unknown command '" << name << "'\n\n";
  PrintHelp(std::cerr);
  return 2;
}
