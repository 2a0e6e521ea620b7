#pragma once
// Runs the real `lbdem` binary (LBDEM_EXE, set by tests/CMakeLists.txt) for
// the command-line tests: exit code and stdout+stderr together.
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace lbdem::test {

struct Result {
  int code;
  std::string out;
};

// args are passed to the shell as written (quote them there).
inline Result run(const std::string& args) {
  const std::string cmd = std::string(LBDEM_EXE) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

}  // namespace lbdem::test
