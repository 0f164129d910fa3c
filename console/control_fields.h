#pragma once
// The fields of a control's JSON body (POST /api/...), each read with the
// type and range it must have. A wrong one throws std::invalid_argument
// naming the field, what it got and what it must be (the console answers
// 400 with it). Lengths of text count characters, i.e. Unicode code points
// of the UTF-8 text (the JSON parser has already refused invalid UTF-8):
// "é" is one character, two bytes.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticlab::console {

// The body as a JSON object; an empty body (no Content-Length, or 0) is {}.
// Throws std::invalid_argument for text that is not a JSON object, and for
// one that gives a key twice in an object (the parser would keep one value
// and drop the other unread).
nlohmann::json parse_control_body(const std::string& body);

// Throws std::invalid_argument naming the first key of `body` that is not
// one of `fields`, the fields `request` takes: a misspelt optional field
// ("stepp") would otherwise be ignored and its default used.
void check_field_names(const nlohmann::json& body, const std::string& request, const std::vector<std::string>& fields);

// Code points of UTF-8 text.
std::size_t utf8_chars(const std::string& text);

// A string of 1..max_chars characters without a NUL (U+0000). Required.
std::string text_field(const nlohmann::json& body, const char* name, std::size_t max_chars);
// As text_field, or `fallback` when absent; "" allowed when allow_empty.
std::string optional_text_field(const nlohmann::json& body, const char* name, std::size_t max_chars,
                                const std::string& fallback, bool allow_empty);
// true or false, or `fallback` when absent.
bool bool_field(const nlohmann::json& body, const char* name, bool fallback);
// A finite number in [min, max]. Required.
double number_field(const nlohmann::json& body, const char* name, double min, double max);
// A whole number in [min, max], checked as a 64-bit integer (a larger one
// is out of range, never wrapped), or `fallback` when absent.
std::int64_t integer_field(const nlohmann::json& body, const char* name, std::int64_t min, std::int64_t max,
                           std::int64_t fallback);

}  // namespace hapticlab::console
