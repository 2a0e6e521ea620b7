#include "core/signals.hpp"

#include <csignal>
#include <cstring>
#include <ctime>

namespace lbdem {

namespace {

volatile std::sig_atomic_t g_stop_signal = 0;
// When the first stop signal arrived (CLOCK_MONOTONIC); touched by the handler
// only, which both signals block while it runs (no re-entry).
timespec g_first_signal{};

// A second signal this soon after the first is the same request delivered
// twice: `timeout`, shells and batch systems signal the process and its
// process group, so the process sees two SIGTERMs microseconds apart.
constexpr double kDuplicateWindowSeconds = 1.0;

extern "C" void on_stop_signal(int sig) {
  // Async-signal-safe calls only: clock_gettime, sigaction, raise.
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  if (g_stop_signal == 0) {
    g_first_signal = now;
    g_stop_signal = sig;
    return;
  }
  const double since = double(now.tv_sec - g_first_signal.tv_sec) + 1e-9 * double(now.tv_nsec - g_first_signal.tv_nsec);
  if (since < kDuplicateWindowSeconds) return;
  // A second request: the default action (terminate). The signal is blocked
  // while this handler runs, so the raised one is delivered on return.
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof dfl);
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(SIGINT, &dfl, nullptr);
  sigaction(SIGTERM, &dfl, nullptr);
  raise(sig);
}

}  // namespace

void install_stop_handlers() {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaddset(&sa.sa_mask, SIGINT);
  sigaddset(&sa.sa_mask, SIGTERM);
  // SA_RESTART: a write in progress (HDF5, CSV) resumes instead of failing with EINTR.
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool stop_requested() noexcept { return g_stop_signal != 0; }

int stop_signal() noexcept { return g_stop_signal; }

const char* stop_signal_name() noexcept {
  switch (g_stop_signal) {
    case 0: return "";
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    default: return "a signal";
  }
}

void clear_stop_request() noexcept { g_stop_signal = 0; }

}  // namespace lbdem
