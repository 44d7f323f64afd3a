// The sub-commands of the shape-slam tool. Each takes the arguments after its name and returns
// the process exit code; it throws UsageError (exit 2) or any std::exception (exit 1), which
// main() reports.
#pragma once

#include <string>
#include <vector>

namespace shape_slam::app {

using Args = std::vector<std::string>;

int RunExtract(const Args& args);
int RunRun(const Args& args);
int RunEval(const Args& args);
int RunMatch(const Args& args);
int RunConvert(const Args& args);
int RunLocalize(const Args& args);

}  // namespace shape_slam::app
