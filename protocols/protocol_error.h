#pragma once
// The one exception every protocol check throws.

#include <cstddef>
#include <stdexcept>
#include <string>

namespace hapticlab::protocols {

// A protocol that breaks a rule. what() reads
//   "<source>: protocol field '<field>' <message>"
// e.g. "study.json: protocol field 'design.k' is 7, but must be >= 0 and <= 5
// (the number of optional settings)". field() is the JSON path alone, so
// callers (and tests) can tell which field without parsing the text.
class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(const std::string& source, const std::string& field, const std::string& message)
      : std::runtime_error(source + ": protocol field '" + field + "' " + message),
        field_(field) {}

  const std::string& field() const noexcept { return field_; }

 private:
  std::string field_;
};

// The path of element i of the list at `base`: "design.required[2]".
inline std::string index_path(const std::string& base, std::size_t i) {
  return base + "[" + std::to_string(i) + "]";
}

}  // namespace hapticlab::protocols
