#include "app/cli/cli_checks.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <optional>
#include <regex>
#include <type_traits>

#include "core/common/csv_format.h"

namespace hapticlab::app {
// Named, not anonymous: the app's files are compiled as unity batches,
// where anonymous helpers of two files would collide.
namespace cli_checks_detail {

std::string refused(const std::string& value, const std::string& rule) {
  return "'" + value + "' is refused: must be " + rule;
}

// The whole of `text` as a decimal double (strtod's syntax without its
// hexadecimal form: "0x0.2" is 0.125 s to strtod, which a banner printing
// "0.1 s" would hide; the whole-number options refuse "0x3" too), or nothing.
std::optional<double> parse_number(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return std::nullopt;
  if (text.find_first_of("xX") != std::string::npos) return std::nullopt;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return x;
}

// The whole of `text` as decimal digits with an optional leading '-', or nothing.
template <typename Int>
std::optional<Int> parse_whole(const std::string& text) {
  Int x{};
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (first == last || (*first == '-' && std::is_unsigned_v<Int>)) return std::nullopt;
  const auto r = std::from_chars(first, last, x, 10);
  if (r.ec != std::errc{} || r.ptr != last) return std::nullopt;
  return x;
}

std::string range_text(double lo, double hi) {
  return "from " + format_number(lo) + " to " + format_number(hi);
}

CLI::Validator finite_where(std::function<bool(double)> ok, std::string rule, std::string description) {
  return CLI::Validator(
      [ok = std::move(ok), rule](std::string& value) {
        const std::optional<double> x = parse_number(value);
        if (!x || !std::isfinite(*x) || !ok(*x)) return refused(value, "a finite number " + rule);
        return std::string();
      },
      std::move(description));
}

template <typename T>
std::optional<T> list_item(const std::string& item) {
  if constexpr (std::is_same_v<T, std::string>) {
    return item;
  } else if constexpr (std::is_same_v<T, int>) {
    return parse_whole<int>(item);
  } else {
    const std::optional<double> x = parse_number(item);
    if (!x || !std::isfinite(*x)) return std::nullopt;
    return x;
  }
}

template <typename T>
const char* list_item_rule() {
  if constexpr (std::is_same_v<T, std::string>) return "text";
  else if constexpr (std::is_same_v<T, int>) return "a whole number";
  else return "a finite number";
}

// The option of `name` in the command `app` parsed, or null.
const CLI::Option* parsed_option(CLI::App& app, const std::string& name) {
  CLI::App* current = &app;
  const CLI::Option* found = nullptr;
  for (;;) {
    for (const CLI::Option* o : current->get_options())
      if (o->check_name(name)) found = o;
    const std::vector<CLI::App*> parsed = current->get_subcommands();
    if (parsed.empty()) return found;
    current = parsed.front();
  }
}

}  // namespace cli_checks_detail


CLI::Validator number_in(double lo, double hi) {
  const std::string range = cli_checks_detail::range_text(lo, hi);
  return cli_checks_detail::finite_where([lo, hi](double x) { return x >= lo && x <= hi; }, range, "NUMBER " + range);
}

CLI::Validator positive_number() {
  return cli_checks_detail::finite_where([](double x) { return x > 0.0; }, "> 0", "NUMBER > 0");
}

CLI::Validator non_negative_number() {
  return cli_checks_detail::finite_where([](double x) { return x >= 0.0; }, ">= 0", "NUMBER >= 0");
}

CLI::Validator whole_number_in(long long lo, long long hi) {
  const std::string rule = "a whole number from " + std::to_string(lo) + " to " + std::to_string(hi);
  return CLI::Validator(
      [lo, hi, rule](std::string& value) {
        const std::optional<long long> x = cli_checks_detail::parse_whole<long long>(value);
        if (!x || *x < lo || *x > hi) return cli_checks_detail::refused(value, rule);
        return std::string();
      },
      "INT from " + std::to_string(lo) + " to " + std::to_string(hi));
}

CLI::Validator seed_number() {
  const std::string rule =
      "a whole number from 0 to " + std::to_string(std::numeric_limits<std::uint64_t>::max()) + " (decimal digits)";
  return CLI::Validator(
      [rule](std::string& value) {
        if (!cli_checks_detail::parse_whole<std::uint64_t>(value)) return cli_checks_detail::refused(value, rule);
        return std::string();
      },
      "SEED 0..2^64-1");
}

template <typename T>
CLI::Option* add_list_option(CLI::App& cmd, const std::string& name, std::vector<T>& out,
                             const std::string& description, const CLI::Validator& item_check) {
  CLI::Option* opt = cmd.add_option(
      name,
      [&out, name, item_check](const CLI::results_t& given) {
        std::vector<T> items;
        for (const std::string& text : given) {
          std::size_t start = 0;
          for (;;) {
            const std::size_t comma = text.find(',', start);
            std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
            if (item.empty())
              throw CLI::ValidationError(name, "'" + text + "' is refused: an empty item in the comma-separated "
                                               "list (give each item once, as a,b,c)");
            if (const std::string problem = item_check(item); !problem.empty())
              throw CLI::ValidationError(name, problem);
            std::optional<T> value = cli_checks_detail::list_item<T>(item);
            if (!value)
              throw CLI::ValidationError(name,
                                         cli_checks_detail::refused(item, cli_checks_detail::list_item_rule<T>()));
            items.push_back(std::move(*value));
            if (comma == std::string::npos) break;
            start = comma + 1;
          }
        }
        out = std::move(items);
        return true;
      },
      description, false);
  opt->type_name("LIST");
  opt->type_size(1, 1);
  opt->expected(1, CLI::detail::expected_max_vector_size);
  return opt;
}

template CLI::Option* add_list_option<std::string>(CLI::App&, const std::string&, std::vector<std::string>&,
                                                   const std::string&, const CLI::Validator&);
template CLI::Option* add_list_option<int>(CLI::App&, const std::string&, std::vector<int>&, const std::string&,
                                           const CLI::Validator&);
template CLI::Option* add_list_option<double>(CLI::App&, const std::string&, std::vector<double>&,
                                              const std::string&, const CLI::Validator&);

std::string argument_mismatch_text(CLI::App& app, const std::string& what) {
  static const std::regex at_most(R"(^(\S+): At Most (\d+) required but received (\d+)$)");
  static const std::regex missing(R"(^(\S+): (\d+) required (\S+) missing$)");
  std::smatch m;
  if (std::regex_match(what, m, at_most)) {
    std::string values;
    if (const CLI::Option* o = cli_checks_detail::parsed_option(app, m[1].str()))
      for (const std::string& v : o->results()) values += (values.empty() ? "'" : ", '") + v + "'";
    return m[1].str() + " is given " + m[3].str() + " values" + (values.empty() ? "" : " (" + values + ")") +
           ", but takes " + (m[2].str() == "1" ? "one: give it once" : "at most " + m[2].str());
  }
  if (std::regex_match(what, m, missing))
    return m[1].str() + " is given without a value, but needs " + (m[2].str() == "1" ? "one" : m[2].str()) + " (" +
           m[3].str() + ")";
  return what;
}

}  // namespace hapticlab::app
