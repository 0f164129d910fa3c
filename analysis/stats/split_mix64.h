#pragma once
// The bootstrap's generator is SplitMix64 from core/common/random.h (one
// implementation for the simulation, the schedules and the statistics): a
// bootstrap run is reproducible from its seed on any compiler and standard
// library, which std::uniform_int_distribution is not.
#include "core/common/random.h"

namespace hapticlab::analysis {

using SplitMix64 = hapticlab::SplitMix64;

}  // namespace hapticlab::analysis
