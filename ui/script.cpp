#include "ui/script.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "core/config.h"

namespace dd::ui {
namespace {

Eigen::Vector2d hold_direction(const std::string& name, const std::string& where) {
  if (name == "Up") return {0, 1};
  if (name == "Down") return {0, -1};
  if (name == "Left") return {-1, 0};
  if (name == "Right") return {1, 0};
  throw Error(where + ": unknown direction '" + name + "' (Up, Down, Left, Right)");
}


}  // namespace

std::vector<ScriptEvent> load_script(const std::string& path) {
  if (!std::filesystem::exists(path)) throw Error(path + ": no such script file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw Error(path + ": malformed YAML: " + e.what());
  }
  if (!root.IsSequence()) throw Error(path + ": a script is a list of events, e.g. - {on: query, after: 8, do: take_over}");
  std::vector<ScriptEvent> out;
  for (size_t i = 0; i < root.size(); ++i) {
    const YAML::Node n = root[i];
    const std::string where = path + ": event " + std::to_string(i + 1);
    if (!n.IsMap()) throw Error(where + ": must be a map");
    ScriptEvent e;
    try {
      for (const auto& kv : n) {
        const std::string k = kv.first.as<std::string>();
        if (k == "at") e.at = kv.second.as<int>();
        else if (k == "on") e.on = kv.second.as<std::string>();
        else if (k == "after") e.after = kv.second.as<int>();
        else if (k == "do" || k == "key") {
          if (e.command) throw Error(where + ": give one of 'do' (a command) or 'key'");
          const std::string v = kv.second.as<std::string>();
          e.command = k == "do" ? command_named(v, where + ": field 'do'") : command_for_key_name(v, where + ": field 'key'");
        }
        else if (k == "hold") e.hold = hold_direction(kv.second.as<std::string>(), where);
        else if (k == "frames") e.frames = kv.second.as<int>();
        else throw Error(where + ": unknown field '" + k + "' (at, on, after, do, key, hold, frames)");
      }
    } catch (const YAML::Exception& ex) {
      throw Error(where + ": " + ex.what());
    }
    if ((e.at < 0) == e.on.empty()) throw Error(where + ": give exactly one of 'at' (a frame) or 'on' (an event)");
    if (!e.on.empty() && e.on != "query" && e.on != "update" && e.on != "takeover" && e.on != "episode")
      throw Error(where + ": field 'on' must be query, update, takeover or episode, not '" + e.on + "'");
    if (!e.command && e.hold.isZero()) throw Error(where + ": give a command ('do') or a 'hold'");
    if (e.frames < 1 || e.after < 0) throw Error(where + ": 'frames' must be >= 1 and 'after' >= 0");
    e.start = e.at;
    out.push_back(e);
  }
  return out;
}

}  // namespace dd::ui
