// Runs a shell command from a test and captures what it printed.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include <sys/wait.h>

namespace tescalib_test {

/// The command's exit status (-1 when it did not exit normally) and what it printed (stdout and
/// stderr).
inline int runCommand(const std::string& command, std::string* output) {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  if (!pipe) return -1;
  char buffer[4096];
  output->clear();
  while (size_t n = fread(buffer, 1, sizeof(buffer), pipe.get())) output->append(buffer, n);
  const int status = pclose(pipe.release());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace tescalib_test
