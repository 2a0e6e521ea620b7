// libFuzzer target for the case loader: the input bytes are read as a case
// file (Config::from_string) and checked the way `lbdem check` checks it
// (run_case with validate_only, quiet, the host backend). A clean rejection
// is an lbdem::Error (ConfigError, ResourceError, ...); anything else (another
// exception, a crash, an ASan/UBSan report, a leak, a timeout, an allocation
// past -rss_limit_mb) is a finding.
//
// The memory checks answer for a machine with 512 MiB free (as `lbdem check
// --memory 512MiB`): every shipped case fits, and the largest grid or particle
// count an input can ask for stays small enough that validating it (a random
// packing and its overlap check are linear in the particle count) fits the
// fuzzer's time limit per input.
//
// Nothing of the loader's own output reaches the terminal: the harness turns
// the log off and sends stdout (the memory table `lbdem check` prints) to
// /dev/null once, before the first input, so that the fuzzer's time goes to
// the loader and the logging code's coverage does not steer it towards the
// slow inputs that validate far enough to print. The harness's own reports and
// libFuzzer's go to stderr, which stays open.
#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <string>

#include <spdlog/spdlog.h>

#include "cases/scenes.hpp"
#include "core/buffer.hpp"
#include "core/config.hpp"
#include "core/error.hpp"

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  spdlog::set_level(spdlog::level::off);
  std::fflush(stdout);
  const int null = ::open("/dev/null", O_WRONLY);
  if (null >= 0) {
    ::dup2(null, STDOUT_FILENO);
    ::close(null);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  lbdem::set_memory_limit(std::size_t{512} << 20);
  const std::string text(reinterpret_cast<const char*>(data), size);
  lbdem::RunOptions opt;
  opt.backend = "cpu";
  opt.quiet = true;
  opt.validate_only = true;
  try {
    const lbdem::Config cfg = lbdem::Config::from_string(text, "<fuzz>");
    (void)lbdem::run_case(cfg, opt);
  } catch (const lbdem::Error&) {
    // A clean, typed rejection of bad input.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_case: untyped exception: %s\n", e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fuzz_case: unknown exception\n");
    std::abort();
  }
  return 0;
}
