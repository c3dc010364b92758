#pragma once
// One table of an enum's names, for to_string and parse alike:
//
//   constexpr auto kFormatNames = enum_names<Format>({{Format::kTum, "tum"}, {Format::kKitti, "kitti"}});
//   const char* to_string(Format f) { return kFormatNames.name(f); }
//
// Like an exhaustive switch under -Wswitch, the table fails to compile
// unless it names every enumerator, once, in declaration order: a new
// enumerator cannot go without a name. For enums whose enumerators run
// 0, 1, 2, ... (no explicit values).

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace sitepose {
namespace detail {

// GCC and Clang spell a template argument that is an enumerator by its name
// ("V = sitepose::TrackingState::kOk"), any other value as a cast
// ("V = (sitepose::TrackingState)3").
template <auto V>
consteval bool is_enumerator() {
  const std::string_view signature = __PRETTY_FUNCTION__;
  const std::size_t at = signature.find("V = ");
  return at != std::string_view::npos && signature[at + 4] != '(';
}

// The number of enumerators of E counted from 0 up to the first value no
// enumerator has.
template <typename E, std::size_t N = 0>
consteval std::size_t enumerator_count() {
  if constexpr (is_enumerator<static_cast<E>(N)>()) {
    return enumerator_count<E, N + 1>();
  } else {
    return N;
  }
}

// Not constexpr: enum_names() calls it, and so fails to compile, when its
// table is incomplete or out of order.
inline void enum_names_must_list_every_enumerator_once_in_declaration_order() {}

}  // namespace detail

template <typename E, std::size_t N>
class EnumNames {
 public:
  constexpr EnumNames(const std::array<const char*, N>& names, const char* other)
      : names_(names), other_(other) {}

  // The enumerator's name; `other` (enum_names()) for a value no enumerator has.
  constexpr const char* name(E value) const {
    const auto index = static_cast<std::size_t>(value);
    return index < N ? names_[index] : other_;
  }

  // The enumerator named exactly `name`; nullopt when none is.
  std::optional<E> parse(std::string_view name) const {
    for (std::size_t i = 0; i < N; ++i) {
      if (name == names_[i]) return static_cast<E>(i);
    }
    return std::nullopt;
  }

  // The names in declaration order, separated by `separator`: "tum, kitti, euroc".
  std::string joined(std::string_view separator) const {
    std::string out;
    for (std::size_t i = 0; i < N; ++i) out.append(i == 0 ? "" : separator).append(names_[i]);
    return out;
  }

 private:
  std::array<const char*, N> names_;
  const char* other_;
};

// `entries` pairs every enumerator of E with its name, in declaration order.
template <typename E, std::size_t N>
consteval EnumNames<E, N> enum_names(const std::pair<E, const char*> (&entries)[N], const char* other = "?") {
  if (N != detail::enumerator_count<E>())
    detail::enum_names_must_list_every_enumerator_once_in_declaration_order();
  std::array<const char*, N> names{};
  for (std::size_t i = 0; i < N; ++i) {
    if (entries[i].first != static_cast<E>(i)) {
      detail::enum_names_must_list_every_enumerator_once_in_declaration_order();
    }
    names[i] = entries[i].second;
  }
  return EnumNames<E, N>(names, other);
}

}  // namespace sitepose
