#pragma once
// What the command line accepts as a number, a seed or a list, with
// refusals that name the option, the value and what is allowed:
//
//   --max-trial-s: 'inf' is refused: must be a finite number from 1 to 3600
//   --seed: '-1' is refused: must be a whole number from 0 to 18446744073709551615
//   --effects: ',' is refused: an empty item in the comma-separated list
//
// CLI11's own checks print DBL_MAX in full (PositiveNumber), let NaN through
// (Range compares with < and >), parse a seed with strtoull (so -1 became
// 18446744073709551615, 0x10 was 16 and a 20-digit number saturated), and
// its comma-separated lists silently drop empty items (then "--effects ,"
// took the next option as its value).

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace hapticlab::app {

// A finite number (decimal, as strtod reads it) in [lo, hi].
CLI::Validator number_in(double lo, double hi);
// A finite number > 0, or >= 0.
CLI::Validator positive_number();
CLI::Validator non_negative_number();
// A whole number written in decimal digits (a leading '-' only when lo < 0)
// in [lo, hi].
CLI::Validator whole_number_in(long long lo, long long hi);
// A seed: decimal digits only, 0..2^64-1.
CLI::Validator seed_number();

// A comma-separated list option, which may also be repeated: every item
// must be non-empty and pass `item_check` (none: any text). The items
// replace `out`'s contents (its initial ones are the default). T:
// std::string, int or double.
template <typename T>
CLI::Option* add_list_option(CLI::App& cmd, const std::string& name, std::vector<T>& out,
                             const std::string& description, const CLI::Validator& item_check = {});

// A friendlier text for CLI11's ArgumentMismatch ("--seed: At Most 1
// required but received 2", "--out: 1 required TEXT missing"), naming the
// values when the option in `app`'s parsed command has them; `what`
// unchanged when it is not one of those.
std::string argument_mismatch_text(CLI::App& app, const std::string& what);

}  // namespace hapticlab::app
