// Strict reading of JSON config sections, shared by the config readers in core (internal header).
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/config.h"

namespace dd::json_read {

/// Rejects keys of `j` that are not in `allowed`, naming the first unknown one and listing the known.
inline void require_known_keys(const nlohmann::json& j, const std::set<std::string>& allowed, const std::string& what) {
  if (!j.is_object()) throw Error(what + ": expected an object");
  for (const auto& [key, value] : j.items()) {
    if (!allowed.count(key)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw Error(what + ": unknown key '" + key + "' (known: " + list + ")");
    }
  }
}

template <typename T>
struct is_list : std::false_type {};
template <typename T, typename A>
struct is_list<std::vector<T, A>> : std::true_type {};
template <typename T, size_t N>
struct is_list<std::array<T, N>> : std::true_type {};

/// Throws Error naming `where` when a number in `v` does not fit the integer type it is read into
/// (nlohmann converts with a plain cast: 1e20 into an int is undefined behaviour; tests/fuzz found it).
template <typename T>
void check_fits(const nlohmann::json& v, const std::string& where) {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    using L = std::numeric_limits<T>;
    const std::string range = "a whole number in [" + std::to_string(L::min()) + ", " + std::to_string(L::max()) + "]";
    if (v.is_number_float()) {
      const double d = v.template get<double>();
      if (!(d >= static_cast<double>(L::min()) && d <= static_cast<double>(L::max())) || d != std::floor(d))
        throw Error(where + ": " + v.dump() + " is not " + range);
    } else if (v.is_number_unsigned()) {
      if (v.template get<uint64_t>() > static_cast<uint64_t>(L::max())) throw Error(where + ": " + v.dump() + " is not " + range);
    } else if (v.is_number_integer()) {
      const int64_t x = v.template get<int64_t>();
      if (x < static_cast<int64_t>(L::min()) || (x > 0 && static_cast<uint64_t>(x) > static_cast<uint64_t>(L::max())))
        throw Error(where + ": " + v.dump() + " is not " + range);
    }
  } else if constexpr (is_list<T>::value) {
    if (v.is_array())
      for (const auto& e : v) check_fits<typename T::value_type>(e, where);
  }
}

/// v.get<T>(), with numbers checked to fit (check_fits) and a type mismatch an Error naming `where`.
template <typename T>
T get_checked(const nlohmann::json& v, const std::string& where) {
  check_fits<T>(v, where);
  try {
    return v.template get<T>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": " + e.what());
  }
}

/// Reads j[key] into out when present; a type mismatch or a number out of range is an Error naming
/// "what.key".
template <typename T>
void read(const nlohmann::json& j, const char* key, T& out, const std::string& what) {
  auto it = j.find(key);
  if (it == j.end()) return;
  out = get_checked<T>(*it, what + "." + key);
}

}  // namespace dd::json_read
