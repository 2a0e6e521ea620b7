#pragma once
// Orderly stop on SIGINT / SIGTERM.
//
// install_stop_handlers() makes the first SIGINT or SIGTERM set a flag and
// nothing else (the only async-signal-safe thing to do); the time loops read
// the flag between steps (a host variable: no device round trip), finish the
// step they are in, write their final output with "interrupted": true and
// return kExitInterrupted. The handler also restores the default action of
// both signals, so a second one ends the process at once.
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
