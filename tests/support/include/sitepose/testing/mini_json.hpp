#pragma once
// A small JSON reader for tests that check tools/can_decode.py output (no
// JSON library is a project dependency). Objects, arrays, strings (\" \\ \/
// \n \t \uXXXX as '?'), numbers as double, true/false/null.

#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace sitepose::testing {

struct Json {
  using Array = std::vector<Json>;
  using Object = std::map<std::string, Json>;
  std::variant<std::nullptr_t, bool, double, std::string, std::shared_ptr<Array>,
               std::shared_ptr<Object>>
      value = nullptr;

  bool is_null() const { return std::holds_alternative<std::nullptr_t>(value); }
  double number() const { return std::get<double>(value); }
  bool boolean() const { return std::get<bool>(value); }
  const std::string& string() const { return std::get<std::string>(value); }
  const Array& array() const { return *std::get<std::shared_ptr<Array>>(value); }
  const Object& object() const { return *std::get<std::shared_ptr<Object>>(value); }
  const Json& operator[](const std::string& key) const { return object().at(key); }
  bool has(const std::string& key) const { return object().count(key) != 0; }
};

class JsonParser {
 public:
  // Keeps a view of `text`: it must outlive the parser.
  explicit JsonParser(std::string_view text) : s_(text) {}
  // nullopt on any syntax error (error() says where).
  std::optional<Json> parse() {
    auto v = value();
    skip();
    if (!v || pos_ != s_.size()) {
      if (error_.empty()) error_ = "trailing characters at " + std::to_string(pos_);
      return std::nullopt;
    }
    return v;
  }
  const std::string& error() const { return error_; }

 private:
  void skip() {
    while (pos_ < s_.size() &&
           (s_[pos_] == ' ' || s_[pos_] == '\n' || s_[pos_] == '\r' || s_[pos_] == '\t'))
      ++pos_;
  }
  std::optional<Json> fail(const std::string& what) {
    error_ = what + " at offset " + std::to_string(pos_);
    return std::nullopt;
  }
  bool literal(std::string_view word) {
    if (s_.substr(pos_, word.size()) != word) return false;
    pos_ += word.size();
    return true;
  }
  std::optional<std::string> string_body() {
    std::string out;
    ++pos_;  // opening quote
    while (pos_ < s_.size() && s_[pos_] != '"') {
      char c = s_[pos_++];
      if (c == '\\') {
        if (pos_ >= s_.size()) return std::nullopt;
        const char e = s_[pos_++];
        if (e == 'n')
          c = '\n';
        else if (e == 't')
          c = '\t';
        else if (e == 'u') {
          pos_ += 4;
          c = '?';
        } else
          c = e;
      }
      out += c;
    }
    if (pos_ >= s_.size()) return std::nullopt;
    ++pos_;  // closing quote
    return out;
  }
  std::optional<Json> value() {
    skip();
    if (pos_ >= s_.size()) return fail("unexpected end");
    const char c = s_[pos_];
    Json j;
    if (c == '{') {
      auto obj = std::make_shared<Json::Object>();
      ++pos_;
      skip();
      if (pos_ < s_.size() && s_[pos_] == '}') {
        ++pos_;
        j.value = obj;
        return j;
      }
      for (;;) {
        skip();
        if (pos_ >= s_.size() || s_[pos_] != '"') return fail("expected a key");
        auto key = string_body();
        if (!key) return fail("bad key");
        skip();
        if (pos_ >= s_.size() || s_[pos_++] != ':') return fail("expected ':'");
        auto v = value();
        if (!v) return std::nullopt;
        (*obj)[*key] = std::move(*v);
        skip();
        if (pos_ < s_.size() && s_[pos_] == ',') {
          ++pos_;
          continue;
        }
        if (pos_ < s_.size() && s_[pos_] == '}') {
          ++pos_;
          break;
        }
        return fail("expected ',' or '}'");
      }
      j.value = obj;
      return j;
    }
    if (c == '[') {
      auto arr = std::make_shared<Json::Array>();
      ++pos_;
      skip();
      if (pos_ < s_.size() && s_[pos_] == ']') {
        ++pos_;
        j.value = arr;
        return j;
      }
      for (;;) {
        auto v = value();
        if (!v) return std::nullopt;
        arr->push_back(std::move(*v));
        skip();
        if (pos_ < s_.size() && s_[pos_] == ',') {
          ++pos_;
          continue;
        }
        if (pos_ < s_.size() && s_[pos_] == ']') {
          ++pos_;
          break;
        }
        return fail("expected ',' or ']'");
      }
      j.value = arr;
      return j;
    }
    if (c == '"') {
      auto str = string_body();
      if (!str) return fail("unterminated string");
      j.value = std::move(*str);
      return j;
    }
    if (literal("true")) {
      j.value = true;
      return j;
    }
    if (literal("false")) {
      j.value = false;
      return j;
    }
    if (literal("null")) {
      j.value = nullptr;
      return j;
    }
    const std::string rest(s_.substr(pos_, 64));
    char* end = nullptr;
    const double d = std::strtod(rest.c_str(), &end);
    if (end == rest.c_str()) return fail("unexpected character");
    pos_ += static_cast<std::size_t>(end - rest.c_str());
    j.value = d;
    return j;
  }

  std::string_view s_;
  std::size_t pos_ = 0;
  std::string error_;
};

}  // namespace sitepose::testing
