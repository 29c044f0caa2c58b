// Runs the caustica binary of the build (CAUSTICA_CLIENT_BIN) for the client tests.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace caustica::testing {

struct ClientRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `caustica ARGS`; ARGS are passed to the shell as they are.
inline ClientRun run_client(const std::string& args) {
  const std::string command = std::string("'") + CAUSTICA_CLIENT_BIN + "' " + args + " 2>&1";
  ClientRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) run.output.append(buffer, n);
  const int status = pclose(pipe);
  if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
  return run;
}

}  // namespace caustica::testing
