#pragma once
// The name of a signal that ended a process, for the operator:
// "SIGSEGV", "SIGKILL", ... and "signal 42" for one without a common name.

#include <string>

namespace hapticlab {

std::string signal_name(int signal_number);

}  // namespace hapticlab
