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

// A shell command line (redirect stderr in it to capture it too).
inline Result run_command(const std::string& cmd) {
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

// args are passed to the shell as written (quote them there).
inline Result run(const std::string& args) { return run_command(std::string(LBDEM_EXE) + " " + args + " 2>&1"); }

#ifdef LBDEM_MPIEXEC
// `lbdem ARGS` on `ranks` ranks under the MPI launcher (one rank: without
// it), one OpenMP thread per rank: the ranks share the machine's cores.
inline std::string ranks_command(int ranks, const std::string& args) {
  const std::string launch = ranks == 1 ? std::string() : std::string(LBDEM_MPIEXEC) + " " + std::to_string(ranks) + " ";
  return "env OMP_NUM_THREADS=1 " + launch + LBDEM_EXE + " " + args;
}
inline Result run_on_ranks(int ranks, const std::string& args) { return run_command(ranks_command(ranks, args) + " 2>&1"); }
#endif

}  // namespace lbdem::test
