#include "console/control_fields.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>
#include <limits>
#include <stdexcept>

namespace hapticlab::console {
namespace {

// What a value is, in the words of a refusal.
std::string kind_of(const nlohmann::json& v) {
  switch (v.type()) {
    case nlohmann::json::value_t::null: return "null";
    case nlohmann::json::value_t::boolean: return "a boolean";
    case nlohmann::json::value_t::string: return "a string";
    case nlohmann::json::value_t::array: return "an array";
    case nlohmann::json::value_t::object: return "an object";
    case nlohmann::json::value_t::number_float: return "a number with a fraction";
    default: return "a number";
  }
}

[[noreturn]] void refuse_field(const char* name, const nlohmann::json& got, const std::string& must) {
  std::string shown = got.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (shown.size() > 80) shown = shown.substr(0, 77) + "...";
  throw std::invalid_argument(std::string(name) + ": " + kind_of(got) + " (" + shown + "), must be " + must);
}

std::string checked_text(const nlohmann::json& v, const char* name, std::size_t max_chars, bool allow_empty) {
  const std::string range = std::string(allow_empty ? "0" : "1") + ".." + std::to_string(max_chars) + " characters";
  if (!v.is_string()) refuse_field(name, v, "a string of " + range);
  const std::string text = v.get<std::string>();
  std::size_t chars = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if ((static_cast<unsigned char>(text[i]) & 0xC0) == 0x80) continue;
    ++chars;
    if (text[i] == '\0')
      throw std::invalid_argument(std::string(name) + ": holds a NUL character (U+0000) at character " +
                                  std::to_string(chars) + "; not accepted (it would cut the text short)");
  }
  if (chars > max_chars || (chars == 0 && !allow_empty))
    throw std::invalid_argument(std::string(name) + ": " + std::to_string(chars) + " characters (" +
                                std::to_string(text.size()) + " bytes), must be " + range +
                                " (characters: Unicode code points)");
  return text;
}

}  // namespace

nlohmann::json parse_control_body(const std::string& body) {
  if (body.empty()) return nlohmann::json::object();
  // A key given twice would leave one of its values unread (the parser
  // keeps the last): {"participant": "S1", "participant": "S2"} started S2.
  std::vector<std::set<std::string>> keys;  // per open object
  std::string twice;
  const nlohmann::json::parser_callback_t note_keys = [&](int, nlohmann::json::parse_event_t event,
                                                          nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) keys.emplace_back();
    if (event == Event::object_end && !keys.empty()) keys.pop_back();
    if (event == Event::key && !keys.empty() && !keys.back().insert(parsed.get<std::string>()).second &&
        twice.empty())
      twice = parsed.get<std::string>();
    return true;
  };
  nlohmann::json j = nlohmann::json::parse(body, note_keys, false);
  if (j.is_discarded() || !j.is_object())
    throw std::invalid_argument("request body: not a JSON object (send {} or nothing for none; UTF-8 text)");
  if (!twice.empty())
    throw std::invalid_argument("request body: the field '" + twice + "' is given twice (which one was meant?)");
  return j;
}

void check_field_names(const nlohmann::json& body, const std::string& request,
                       const std::vector<std::string>& fields) {
  for (const auto& [key, value] : body.items()) {
    if (std::find(fields.begin(), fields.end(), key) != fields.end()) continue;
    std::string takes;
    for (const std::string& f : fields) takes += (takes.empty() ? "" : ", ") + f;
    std::string shown = key.size() > 64 ? key.substr(0, 61) + "..." : key;
    throw std::invalid_argument("request body: unknown field '" + shown + "' (" + request + " takes " +
                                (takes.empty() ? std::string("no field") : takes) +
                                "; a misspelt field would otherwise be ignored and its default used)");
  }
}

std::size_t utf8_chars(const std::string& text) {
  std::size_t n = 0;
  for (const char c : text) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  return n;
}

std::string text_field(const nlohmann::json& body, const char* name, std::size_t max_chars) {
  if (!body.contains(name))
    throw std::invalid_argument(std::string(name) + ": missing (a string of 1.." + std::to_string(max_chars) +
                                " characters)");
  return checked_text(body[name], name, max_chars, false);
}

std::string optional_text_field(const nlohmann::json& body, const char* name, std::size_t max_chars,
                                const std::string& fallback, bool allow_empty) {
  if (!body.contains(name)) return fallback;
  return checked_text(body[name], name, max_chars, allow_empty);
}

bool bool_field(const nlohmann::json& body, const char* name, bool fallback) {
  if (!body.contains(name)) return fallback;
  const nlohmann::json& v = body[name];
  if (!v.is_boolean()) refuse_field(name, v, "true or false");
  return v.get<bool>();
}

double number_field(const nlohmann::json& body, const char* name, double min, double max) {
  const std::string range = std::to_string(static_cast<long long>(min)) + ".." + std::to_string(static_cast<long long>(max));
  if (!body.contains(name)) throw std::invalid_argument(std::string(name) + ": missing (a number, " + range + ")");
  const nlohmann::json& v = body[name];
  if (!v.is_number()) refuse_field(name, v, "a number, " + range);
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < min || x > max)
    throw std::invalid_argument(std::string(name) + ": " + v.dump() + ", must be " + range);
  return x;
}

std::int64_t integer_field(const nlohmann::json& body, const char* name, std::int64_t min, std::int64_t max,
                           std::int64_t fallback) {
  if (!body.contains(name)) return fallback;
  const nlohmann::json& v = body[name];
  const std::string range = "a whole number, " + std::to_string(min) + ".." + std::to_string(max);
  if (!v.is_number_integer()) refuse_field(name, v, range);
  // Above 2^63 - 1 the parser keeps it unsigned: out of range, not wrapped.
  if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
    throw std::invalid_argument(std::string(name) + ": " + v.dump() + ", must be " + range);
  const std::int64_t x = v.get<std::int64_t>();
  if (x < min || x > max) throw std::invalid_argument(std::string(name) + ": " + v.dump() + ", must be " + range);
  return x;
}

}  // namespace hapticlab::console
