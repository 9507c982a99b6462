// Strict reading of JSON config sections, shared by the config readers in core (internal header).
#pragma once

#include <set>
#include <string>

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

/// Reads j[key] into out when present; a type mismatch is an Error naming "what.key".
template <typename T>
void read(const nlohmann::json& j, const char* key, T& out, const std::string& what) {
  auto it = j.find(key);
  if (it == j.end()) return;
  try {
    out = it->template get<T>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(what + "." + key + ": " + e.what());
  }
}

}  // namespace dd::json_read
