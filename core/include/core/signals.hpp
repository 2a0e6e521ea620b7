#pragma once
// Orderly stop on SIGINT / SIGTERM.
//
// install_stop_handlers() makes the first SIGINT or SIGTERM set a flag and
// nothing else (the only async-signal-safe thing to do); the time loops read
// the flag between steps (a host variable: no device round trip), finish the
// step they are in, write their final output with "interrupted": true and
// return kExitInterrupted. A second signal ends the process at once, unless
// it comes within a second of the first: that is the same request delivered
// twice (to the process and to its process group, as `timeout`, shells and
// batch systems do), and it is ignored.
//
// The flag is process-wide state by necessity: a signal handler can reach
// nothing else.
namespace lbdem {

// Exit code of a run stopped by SIGINT or SIGTERM after writing its final output.
inline constexpr int kExitInterrupted = 5;

// Installs the handlers for SIGINT and SIGTERM (idempotent).
void install_stop_handlers();
// True once a stop signal arrived (cheap: reads one volatile variable).
bool stop_requested() noexcept;
// The signal that asked to stop (0: none) and its name ("SIGINT", "SIGTERM").
int stop_signal() noexcept;
const char* stop_signal_name() noexcept;
// Forgets a stop request (tests).
void clear_stop_request() noexcept;

}  // namespace lbdem
