#pragma once
// A control that cannot act in the console's present state (no session
// runs, no trial runs, one runs already, the device hung): the console
// answers 409 with its message.

#include <stdexcept>

namespace hapticlab::console {

class ConsoleConflict : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hapticlab::console
