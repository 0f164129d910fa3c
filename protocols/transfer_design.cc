#include "protocols/transfer_design.h"

#include <array>

namespace hapticlab::protocols {
namespace {
constexpr std::array<std::string_view, 4> kPhaseNames{"pre_test", "training", "post_test", "retention"};
}  // namespace

std::string_view phase_kind_name(PhaseKind kind) { return kPhaseNames.at(static_cast<std::size_t>(kind)); }

std::optional<PhaseKind> phase_kind_from_name(std::string_view name) {
  for (std::size_t i = 0; i < kPhaseNames.size(); ++i)
    if (kPhaseNames[i] == name) return static_cast<PhaseKind>(i);
  return std::nullopt;
}

}  // namespace hapticlab::protocols
