#pragma once
// The message of an exception a call is expected to throw.

#include <string>

namespace hapticlab::testing {

// What `f` throws as E, its what(); "" if it throws nothing.
template <typename E, typename F>
std::string thrown(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "";
}

}  // namespace hapticlab::testing
